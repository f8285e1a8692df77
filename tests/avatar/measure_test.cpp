#include "mimic/avatar/measure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>

#include <nlohmann/json.hpp>

#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/mesh_io.h"
#include "test_data.h"

namespace mimic::avatar::measure_test {
namespace {

constexpr float kPi = 3.14159265358979f;

// Closed cylinder from a to b, radius r, n sides, outward faces.
void add_cylinder(Mesh& m, glm::vec3 a, glm::vec3 b, float r, int n) {
  const glm::vec3 axis = glm::normalize(b - a);
  const glm::vec3 helper = std::abs(axis.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 u = glm::normalize(glm::cross(axis, helper)), v = glm::cross(axis, u);
  const auto base = static_cast<uint32_t>(m.positions.size());
  for (int end = 0; end < 2; ++end)
    for (int i = 0; i < n; ++i) {
      const float t = 2 * kPi * float(i) / float(n);
      m.positions.push_back((end ? b : a) + r * (std::cos(t) * u + std::sin(t) * v));
    }
  m.positions.push_back(a);
  m.positions.push_back(b);
  const uint32_t ca = base + 2 * n, cb = ca + 1;
  for (int i = 0; i < n; ++i) {
    const uint32_t i0 = base + i, i1 = base + (i + 1) % n, j0 = i0 + n, j1 = i1 + n;
    m.indices.insert(m.indices.end(), {i0, i1, j1, i0, j1, j0, ca, i1, i0, cb, j0, j1});
  }
}

Mesh cylinder(glm::vec3 a, glm::vec3 b, float r, int n = 256) {
  Mesh m;
  add_cylinder(m, a, b, r, n);
  return m;
}

TEST(Measure, CylinderGirthIsTwoPiR) {
  const float r = 0.12f;
  const Mesh m = cylinder({0, 0, 0}, {0, 1, 0}, r);
  EXPECT_TRUE(is_closed_oriented_manifold(analyze_topology(m)));
  const glm::vec3 axis{0, 0.37f, 0};
  const glm::vec3 include[] = {axis};
  const auto g = tape_girth(m, axis, {0, 1, 0}, include);
  ASSERT_TRUE(g);
  EXPECT_NEAR(*g, 2 * kPi * r, 0.01f * 2 * kPi * r);
  // A slice that misses the body, or an axis outside it, measures nothing.
  const glm::vec3 above[] = {glm::vec3(0, 1.5f, 0)};
  EXPECT_FALSE(tape_girth(m, above[0], {0, 1, 0}, above));
  const glm::vec3 outside[] = {glm::vec3(0.5f, 0.37f, 0)};
  EXPECT_FALSE(tape_girth(m, axis, {0, 1, 0}, outside));
}

TEST(Measure, TiltedCylinderMeasuredPerpendicularToItsAxis) {
  const float r = 0.05f;
  const glm::vec3 a{0.2f, 1.4f, 0.1f}, b{0.4f, 1.1f, 0.3f};
  const Mesh m = cylinder(a, b, r);
  const glm::vec3 mid = 0.5f * (a + b);
  const glm::vec3 include[] = {mid};
  const auto g = tape_girth(m, mid, b - a, include);
  ASSERT_TRUE(g);
  EXPECT_NEAR(*g, 2 * kPi * r, 0.01f * 2 * kPi * r);
}

TEST(Measure, BoxGirthIsItsPerimeterAndConcavitiesAreBridged) {
  Mesh m;
  add_cylinder(m, {0, 0, 0}, {0, 1, 0}, 0.1f, 4);  // a square prism, half-diagonal 0.1
  const glm::vec3 axis{0, 0.5f, 0};
  const glm::vec3 include[] = {axis};
  const auto g = tape_girth(m, axis, {0, 1, 0}, include);
  ASSERT_TRUE(g);
  EXPECT_NEAR(*g, 4 * 0.1f * std::sqrt(2.0f), 1e-5f);
  // A star-shaped cross-section: the tape spans the notches (hull of the 5 tips).
  Mesh star;
  const int n = 10;
  for (int end = 0; end < 2; ++end)
    for (int i = 0; i < n; ++i) {
      const float t = 2 * kPi * float(i) / float(n), rad = i % 2 ? 0.04f : 0.1f;
      star.positions.push_back({rad * std::cos(t), float(end), -rad * std::sin(t)});
    }
  star.positions.push_back({0, 0, 0});
  star.positions.push_back({0, 1, 0});
  for (uint32_t i = 0; i < uint32_t(n); ++i) {
    const uint32_t i1 = (i + 1) % n;
    star.indices.insert(star.indices.end(), {i, i1, i1 + n, i, i1 + n, i + n, 2 * n, i1, i, 2 * n + 1, i + n, i1 + n});
  }
  const auto topo = analyze_topology(star);
  EXPECT_TRUE(is_closed_oriented_manifold(topo));
  EXPECT_GT(topo.signed_volume, 0);
  const auto gs = tape_girth(star, axis, {0, 1, 0}, include);
  ASSERT_TRUE(gs);
  EXPECT_NEAR(*gs, 5 * 2 * 0.1f * std::sin(kPi / 5), 1e-5f);
}

TEST(Measure, CrossSectionOfTwoCylindersGivesTwoLoops) {
  Mesh m = cylinder({-0.2f, 0, 0}, {-0.2f, 1, 0}, 0.05f, 32);
  add_cylinder(m, {0.2f, 0, 0}, {0.2f, 1, 0}, 0.08f, 32);
  const auto loops = cross_section(m, {0, 0.5f, 0}, {0, 1, 0});
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_EQ(loops[0].size() + loops[1].size(), 2u * 2 * 32);  // a side edge and a diagonal per quad
  const glm::vec3 right[] = {glm::vec3(0.2f, 0.5f, 0)};
  const auto g = tape_girth(m, {0, 0.5f, 0}, {0, 1, 0}, right);
  ASSERT_TRUE(g);
  EXPECT_NEAR(*g, 2 * kPi * 0.08f, 0.01f);
  // Both loops wrapped together: two arcs plus two bridges of 0.4 m.
  const glm::vec3 both[] = {glm::vec3(0.2f, 0.5f, 0), glm::vec3(-0.2f, 0.5f, 0)};
  const auto g2 = tape_girth(m, {0, 0.5f, 0}, {0, 1, 0}, both);
  ASSERT_TRUE(g2);
  EXPECT_GT(*g2, 0.8f);
  // An excluded point inside a loop refuses that loop.
  EXPECT_FALSE(tape_girth(m, {0, 0.5f, 0}, {0, 1, 0}, right, right));
}

// A body of cylinders, 1.70 m tall: torso r = 0.15 (0.74–1.45 m), head, thighs r = 0.075,
// shins r = 0.05, upper arms r = 0.04 hanging 50° below horizontal beside the torso.
struct CylinderBody {
  Mesh mesh;
  BodyLandmarks lm;
};

CylinderBody cylinder_body() {
  CylinderBody b;
  Mesh& m = b.mesh;
  add_cylinder(m, {0, 0.74f, 0}, {0, 1.45f, 0}, 0.15f, 256);
  add_cylinder(m, {0, 1.46f, 0}, {0, 1.70f, 0}, 0.08f, 64);
  BodyLandmarks& lm = b.lm;
  lm.ground_y_m = 0;
  lm.pelvis_m = {0, 0.95f, 0};
  lm.spine_m = {{0, 1.05f, 0.01f}, {0, 1.2f, -0.01f}};
  lm.neck_m = {0, 1.45f, 0};
  lm.head_m = {0, 1.55f, 0};
  lm.head_top_m = {0, 1.7f, 0};
  const float c = std::cos(50 * kPi / 180), s = std::sin(50 * kPi / 180);
  for (float side : {1.0f, -1.0f}) {
    LimbLandmarks& l = side > 0 ? lm.left : lm.right;
    l.hip_m = {side * 0.09f, 0.80f, 0};
    l.knee_m = {side * 0.09f, 0.47f, 0};
    l.ankle_m = {side * 0.09f, 0.07f, 0};
    l.shoulder_m = {side * 0.21f, 1.40f, 0};
    l.elbow_m = l.shoulder_m + 0.30f * glm::vec3(side * c, -s, 0);
    l.wrist_m = l.elbow_m + 0.25f * glm::vec3(0, -0.6f, 0.8f);
    add_cylinder(m, {side * 0.09f, 0.47f, 0}, {side * 0.09f, 0.735f, 0}, 0.075f, 256);
    add_cylinder(m, {side * 0.09f, 0.0f, 0}, {side * 0.09f, 0.465f, 0}, 0.05f, 256);
    add_cylinder(m, l.shoulder_m, l.elbow_m, 0.04f, 256);
  }
  return b;
}

TEST(Measure, CylinderBodyGirthsAreExact) {
  const CylinderBody b = cylinder_body();
  const BodyMeasurements m = measure_body(b.mesh, b.lm);
  EXPECT_NEAR(m.height_m, 1.70f, 1e-6f);
  const float torso = 2 * kPi * 0.15f;
  ASSERT_TRUE(m.chest_girth_m && m.waist_girth_m && m.hip_girth_m);
  // The arms cross every chest slice beside the torso, and are not wrapped in.
  EXPECT_NEAR(*m.chest_girth_m, torso, 0.01f * torso);
  EXPECT_NEAR(*m.waist_girth_m, torso, 0.01f * torso);
  EXPECT_NEAR(*m.hip_girth_m, torso, 0.01f * torso);
  ASSERT_TRUE(m.thigh_girth_m);
  ASSERT_TRUE(m.calf_girth_m);
  ASSERT_TRUE(m.upper_arm_girth_m);
  EXPECT_NEAR(*m.thigh_girth_m, 2 * kPi * 0.075f, 0.01f * 2 * kPi * 0.075f);
  EXPECT_LT(m.thigh_level_m, 0.74f);  // the slices still inside the torso were skipped
  EXPECT_NEAR(*m.calf_girth_m, 2 * kPi * 0.05f, 0.01f * 2 * kPi * 0.05f);
  EXPECT_NEAR(*m.upper_arm_girth_m, 2 * kPi * 0.04f, 0.01f * 2 * kPi * 0.04f);
  auto vol = [](double r, double h) { return 3.14159265358979 * r * r * h; };
  const double volume =
      vol(0.15, 0.71) + vol(0.08, 0.24) + 2 * (vol(0.075, 0.265) + vol(0.05, 0.465) + vol(0.04, 0.30));
  EXPECT_NEAR(m.volume_m3, volume, 0.005 * volume);
}

TEST(Measure, ArmMergedWithTorsoIsSkippedNotWrapped) {
  CylinderBody b = cylinder_body();
  // A fat disc over chest slices 1.20–1.25 m whose outline encloses both the torso axis and
  // the left arm, as a torso loop does where it has merged with an arm at the armpit.
  add_cylinder(b.mesh, {0, 1.20f, 0}, {0, 1.25f, 0}, 0.40f, 256);
  const BodyMeasurements m = measure_body(b.mesh, b.lm);
  ASSERT_TRUE(m.chest_girth_m);
  // The disc's loop is refused (it would measure 2π·0.40 = 2.5 m); the torso loop inside it counts.
  EXPECT_NEAR(*m.chest_girth_m, 2 * kPi * 0.15f, 0.01f * 2 * kPi * 0.15f);
}

// Where each girth was taken: its tape measures the same girth again, and the tape's hull
// corners lie on the surface, round the limb, with the hull's perimeter the girth.
TEST(Measure, EachGirthsTapeMeasuresItAgain) {
  auto mesh = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(mesh && lm);
  GirthTapes tapes;
  const BodyMeasurements m = measure_body(*mesh, *lm, &tapes);
  EXPECT_EQ(measurements_json(m), measurements_json(measure_body(*mesh, *lm)));
  for (auto [girth, tape, what] :
       {std::tuple{m.chest_girth_m, &tapes.chest, "chest"}, std::tuple{m.waist_girth_m, &tapes.waist, "waist"},
        std::tuple{m.hip_girth_m, &tapes.hips, "hips"}, std::tuple{m.thigh_girth_m, &tapes.thigh, "thigh"},
        std::tuple{m.calf_girth_m, &tapes.calf, "calf"},
        std::tuple{m.upper_arm_girth_m, &tapes.upper_arm, "upper arm"}}) {
    ASSERT_TRUE(girth && *tape) << what;
    EXPECT_EQ(tape_girth(*mesh, **tape), girth) << what;
    const std::vector<glm::vec3> hull = tape_hull(*mesh, **tape);
    ASSERT_GE(hull.size(), 8u) << what;
    double perimeter = 0;
    for (size_t i = 0; i < hull.size(); ++i) {
      perimeter += glm::distance(hull[i], hull[(i + 1) % hull.size()]);
      EXPECT_NEAR(glm::dot(hull[i] - (*tape)->point, glm::normalize((*tape)->normal)), 0.0f, 1e-5f) << what;
    }
    EXPECT_NEAR(perimeter, *girth, 1e-4) << what;
  }
  EXPECT_NEAR(tapes.thigh->point.y - lm->ground_y_m, m.thigh_level_m, 1e-5f);
}

TEST(Measure, LoadsMakeHumanJoints) {
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(lm) << lm.error().what();
  EXPECT_NEAR(lm->ground_y_m, -0.818305f, 1e-6f);
  EXPECT_NEAR(lm->pelvis_m.y, 0.072685f, 1e-6f);
  ASSERT_EQ(lm->spine_m.size(), 4u);
  EXPECT_NEAR(lm->spine_m[0].y, 0.118685f, 1e-6f);  // spine-4, the lowest
  EXPECT_NEAR(lm->spine_m[3].y, 0.432855f, 1e-6f);  // spine-1, the highest
  EXPECT_NEAR(lm->left.shoulder_m.x, 0.167713f, 1e-6f);
  EXPECT_NEAR(lm->left.wrist_m.z, 0.175655f, 1e-6f);
  EXPECT_NEAR(lm->right.hip_m.x, -0.110365f, 1e-6f);
  EXPECT_NEAR(lm->head_top_m.y, 0.840435f, 1e-6f);
}

TEST(Measure, JointCsvErrorsNameTheProblem) {
  auto bad = parse_makehuman_joints("name,x,y,z\npelvis,0,1,zz\n", 0.1f, "j.csv");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, Errc::parse_error);
  EXPECT_NE(bad.error().message.find("j.csv:2:"), std::string::npos);
  auto missing = parse_makehuman_joints("pelvis,0,1,0\n", 0.1f, "j.csv");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_NE(missing.error().message.find("l-knee"), std::string::npos);
  EXPECT_FALSE(parse_makehuman_joints("pelvis,0,1\n"));
  EXPECT_FALSE(load_makehuman_joints("/nonexistent/joints.csv"));
}

// Figures of the MakeHuman base mesh (documented in docs/measurements.md).
TEST(Measure, MakeHumanBaseMeshFigures) {
  auto mesh = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(mesh && lm);
  const BodyMeasurements m = measure_body(*mesh, *lm);
  EXPECT_NEAR(m.height_m, 1.6674f, 0.001f);
  EXPECT_NEAR(m.volume_m3, 0.0549, 0.0001);
  EXPECT_NEAR(m.surface_area_m2, 1.614, 0.001);
  ASSERT_TRUE(m.chest_girth_m && m.waist_girth_m && m.hip_girth_m && m.thigh_girth_m && m.calf_girth_m &&
              m.upper_arm_girth_m);
  EXPECT_NEAR(*m.chest_girth_m, 0.851f, 0.01f);
  EXPECT_NEAR(*m.waist_girth_m, 0.669f, 0.01f);
  EXPECT_NEAR(*m.hip_girth_m, 0.977f, 0.01f);
  EXPECT_NEAR(*m.thigh_girth_m, 0.576f, 0.01f);
  EXPECT_NEAR(*m.calf_girth_m, 0.355f, 0.01f);
  EXPECT_NEAR(*m.upper_arm_girth_m, 0.257f, 0.01f);
  // Anatomical sense: waist < chest < hips, chest just under the armpits, waist above the navel.
  EXPECT_LT(*m.waist_girth_m, *m.chest_girth_m);
  EXPECT_LT(*m.chest_girth_m, *m.hip_girth_m);
  EXPECT_GT(m.chest_level_m, 0.70f * m.height_m);
  EXPECT_LT(m.thigh_level_m, m.hip_level_m + 0.05f);
}

TEST(Measure, EstimatedLandmarksMeasureMakeHumanAlmostLikeItsJoints) {
  auto mesh = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(mesh && lm);
  const BodyLandmarks est = estimate_landmarks(*mesh);
  EXPECT_LT(glm::length(est.left.knee_m - lm->left.knee_m), 0.04f);
  EXPECT_LT(glm::length(est.pelvis_m - lm->pelvis_m), 0.02f);
  const BodyMeasurements ref = measure_body(*mesh, *lm), got = measure_body(*mesh, est);
  EXPECT_FALSE(got.upper_arm_girth_m);  // arms are not located
  BodyMeasurements ref_no_arm = ref;
  ref_no_arm.upper_arm_girth_m.reset();
  EXPECT_TRUE(comparison_passes(got, ref_no_arm, 0.03)) << format_comparison(got, ref_no_arm, 0.03);
}

TEST(Measure, ComparisonTableAndJson) {
  const CylinderBody b = cylinder_body();
  const BodyMeasurements ref = measure_body(b.mesh, b.lm);
  EXPECT_TRUE(comparison_passes(ref, ref));
  BodyMeasurements ours = ref;
  *ours.waist_girth_m *= 1.15f;
  ours.calf_girth_m.reset();
  EXPECT_FALSE(comparison_passes(ours, ref));
  const std::string table = format_comparison(ours, ref);
  EXPECT_NE(table.find("measurement"), std::string::npos);
  EXPECT_NE(table.find("within ±10%"), std::string::npos);
  auto line_of = [&](const std::string& key) {
    const size_t at = table.find(key);
    return at == std::string::npos ? std::string() : table.substr(at, table.find('\n', at) - at);
  };
  EXPECT_NE(line_of("waist girth").find("+15.0"), std::string::npos) << table;
  EXPECT_NE(line_of("waist girth").find("FAIL"), std::string::npos) << table;
  EXPECT_NE(line_of("chest girth").find("PASS"), std::string::npos) << table;
  EXPECT_NE(line_of("calf girth").find("n/a"), std::string::npos) << table;
  EXPECT_NE(line_of("calf girth").find("FAIL"), std::string::npos) << table;
  // Wider tolerance passes the waist.
  EXPECT_NE(format_comparison(ours, ref, 0.2).find("within ±20%"), std::string::npos);

  const auto j = nlohmann::json::parse(comparison_json(ours, ref));
  EXPECT_EQ(j["pass"], false);
  EXPECT_DOUBLE_EQ(j["tolerance"].get<double>(), 0.1);
  bool saw_waist = false;
  for (const auto& r : j["rows"])
    if (r["key"] == "waist_girth") {
      saw_waist = true;
      EXPECT_NEAR(r["difference"].get<double>(), 0.15, 1e-4);
      EXPECT_EQ(r["pass"], false);
      EXPECT_EQ(r["unit"], "cm");
    } else if (r["key"] == "calf_girth") {
      EXPECT_TRUE(r["ours"].is_null());
    }
  EXPECT_TRUE(saw_waist);
  const auto mj = nlohmann::json::parse(measurements_json(ref));
  EXPECT_NEAR(mj["height_cm"].get<double>(), 170.0, 1e-3);
  EXPECT_TRUE(mj.contains("chest_girth_cm"));
  EXPECT_TRUE(mj.contains("levels_above_ground_m"));
}

double angle_deg(glm::vec3 a, glm::vec3 b) {
  const double c = glm::dot(glm::normalize(glm::dvec3(a)), glm::normalize(glm::dvec3(b)));
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / 3.14159265358979;
}

// Limb directions of `pose` against the landmarks' segments, worst case in degrees.
double worst_limb_error_deg(const rig::Skeleton& s, const rig::Pose& pose, const BodyLandmarks& lm) {
  std::vector<rig::RigidTransform> w(s.joint_count());
  rig::forward_kinematics(s, pose, w);
  auto at = [&](const std::string& n) { return w[s.find_joint(n)].translation; };
  double worst = 0;
  for (auto [side, limb] : {std::pair{"l_", &lm.left}, std::pair{"r_", &lm.right}}) {
    const std::string p(side);
    worst = std::max(worst, angle_deg(at(p + "elbow") - at(p + "shoulder"), limb->elbow_m - limb->shoulder_m));
    worst = std::max(worst, angle_deg(at(p + "wrist") - at(p + "elbow"), limb->wrist_m - limb->elbow_m));
    worst = std::max(worst, angle_deg(at(p + "knee") - at(p + "hip"), limb->knee_m - limb->hip_m));
    worst = std::max(worst, angle_deg(at(p + "ankle") - at(p + "knee"), limb->ankle_m - limb->knee_m));
  }
  return worst;
}

TEST(Measure, PoseToMatchPutsMimicInTheMakeHumanAPose) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(s);
  auto lm = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(lm);
  EXPECT_GT(worst_limb_error_deg(*s, s->zero_pose(), *lm), 30.0);  // the T-pose is far off
  const rig::Pose pose = pose_to_match(*s, *lm);
  EXPECT_LT(worst_limb_error_deg(*s, pose, *lm), 2.0);
  EXPECT_EQ(pose.root_position_m, lm->pelvis_m);
  // Every DOF within its limits, and the posture mirror-symmetric like the reference.
  for (int i = 0; i < s->dof_count(); ++i) {
    EXPECT_GE(pose.dof_rad[i], s->dof(i).min_rad - 1e-6f) << s->dof(i).name;
    EXPECT_LE(pose.dof_rad[i], s->dof(i).max_rad + 1e-6f) << s->dof(i).name;
  }
  for (const char* d : {"shoulder_abduction", "shoulder_flexion", "elbow_flexion", "hip_abduction", "knee_flexion"})
    EXPECT_NEAR(pose.dof_rad[s->find_dof(std::string("l_") + d)], pose.dof_rad[s->find_dof(std::string("r_") + d)],
                0.01)
        << d;
  // Upper arms about 50° below horizontal, as the data's README says.
  std::vector<rig::RigidTransform> w(s->joint_count());
  rig::forward_kinematics(*s, pose, w);
  const glm::vec3 upper = w[s->find_joint("l_elbow")].translation - w[s->find_joint("l_shoulder")].translation;
  EXPECT_NEAR(std::atan2(-upper.y, upper.x) * 180 / kPi, 50.0, 2.0);
}

TEST(Measure, PoseToMatchRecoversRandomReachablePostures) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(s);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> unit(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    rig::Pose truth = s->zero_pose();
    truth.root_position_m = {0.1f, 0.9f, -0.2f};
    for (const char* side : {"l_", "r_"})
      for (const char* d : {"shoulder_flexion", "shoulder_abduction", "shoulder_twist", "elbow_flexion", "hip_flexion",
                            "hip_abduction", "hip_rotation", "knee_flexion"}) {
        const int i = s->find_dof(std::string(side) + d);
        const auto& f = s->dof(i);
        // Stay clear of the limits and of a straight elbow/knee, where twist is unobservable.
        float lo = f.min_rad + 0.2f * (f.max_rad - f.min_rad), hi = f.max_rad - 0.2f * (f.max_rad - f.min_rad);
        if (std::string(d) == "elbow_flexion" || std::string(d) == "knee_flexion") lo = std::max(lo, 0.3f);
        truth.dof_rad[i] = lo + unit(rng) * (hi - lo);
      }
    const BodyLandmarks lm = landmarks_from_skeleton(*s, truth);
    const rig::Pose solved = pose_to_match(*s, lm);
    EXPECT_LT(worst_limb_error_deg(*s, solved, lm), 0.5) << "trial " << trial;
  }
}

TEST(Measure, LandmarkCsvRoundTrips) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(s);
  const BodyLandmarks lm = landmarks_from_skeleton(*s, s->zero_pose());
  auto back = parse_makehuman_joints(format_landmarks_csv(lm, 10.0f), 0.1f);
  ASSERT_TRUE(back) << back.error().what();
  EXPECT_NEAR(back->ground_y_m, lm.ground_y_m, 1e-6f);
  ASSERT_EQ(back->spine_m.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_LT(glm::length(back->spine_m[i] - lm.spine_m[i]), 1e-6f);
  EXPECT_LT(glm::length(back->head_top_m - lm.head_top_m), 1e-6f);
  EXPECT_LT(glm::length(back->left.wrist_m - lm.left.wrist_m), 1e-6f);
  EXPECT_LT(glm::length(back->right.ankle_m - lm.right.ankle_m), 1e-6f);
  // And MakeHuman's own landmarks survive the trip with their four spine joints in order.
  auto mh = load_makehuman_joints(test::shared_data("mesh/makehuman_base_joints.csv"));
  ASSERT_TRUE(mh);
  auto mh_back = parse_makehuman_joints(format_landmarks_csv(*mh), 1.0f);
  ASSERT_TRUE(mh_back);
  ASSERT_EQ(mh_back->spine_m.size(), 4u);
  EXPECT_LT(glm::length(mh_back->spine_m[0] - mh->spine_m[0]), 1e-6f);
  EXPECT_LT(glm::length(mh_back->spine_m[3] - mh->spine_m[3]), 1e-6f);
}

TEST(Measure, LandmarksFromSkeletonStandOnTheGround) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(s);
  rig::Pose p = s->zero_pose();
  p.root_position_m = {0, rig::standing_root_height_m(*s), 0};
  const BodyLandmarks lm = landmarks_from_skeleton(*s, p);
  EXPECT_NEAR(lm.ground_y_m, 0.0f, 1e-5f);
  EXPECT_EQ(lm.spine_m.size(), 3u);
  EXPECT_GT(lm.head_top_m.y, lm.head_m.y);
  EXPECT_GT(lm.left.shoulder_m.x, 0);
  EXPECT_LT(lm.right.shoulder_m.x, 0);
}

}  // namespace
}  // namespace mimic::avatar::measure_test
