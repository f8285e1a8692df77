// Joint-zone volume and cross-sections on shapes whose answers are known, and the volume loss
// linear blend skinning is known for.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "mimic/avatar/baselines/baseline_skinner.h"
#include "mimic/avatar/joint_zone.h"
#include "mimic/avatar/mesh_check.h"
#include "two_bone_cylinder.h"

namespace mimic::avatar::joint_zone_test {
namespace {

using testing::cylinder_mesh;
constexpr double kPi = std::numbers::pi;

std::vector<uint32_t> all_triangles(const Mesh& m) {
  std::vector<uint32_t> t(m.triangle_count());
  for (uint32_t i = 0; i < t.size(); ++i) t[i] = i;
  return t;
}

// Area of the regular 48-gon of radius 5 cm the cylinder's rings are.
const double kRingArea = 0.5 * 48 * 0.05 * 0.05 * std::sin(2 * kPi / 48);

TEST(JointZone, SlabOfACylinderIsItsRingAreaTimesItsThickness) {
  const Mesh m = cylinder_mesh();
  const auto tris = all_triangles(m);
  const JointZone z{{0.3f, 0, 0}, {-1, 0, 0}, {1, 0, 0}, 0.1f};
  EXPECT_NEAR(joint_zone_volume(m.positions, m.indices, tris, z), kRingArea * 0.2, 1e-9);
  // Off-centre slab reaching past one cap: only the inside counts.
  const JointZone end{{0.55f, 0, 0}, {-1, 0, 0}, {1, 0, 0}, 0.1f};
  EXPECT_NEAR(joint_zone_volume(m.positions, m.indices, tris, end), kRingArea * 0.15, 1e-9);
}

TEST(JointZone, AZoneHoldingTheWholeMeshGivesItsVolume) {
  const Mesh m = cylinder_mesh(31, 40, 0.07f, 0.5f);
  const JointZone z{{0.25f, 0.01f, 0}, {-0.6f, 0.8f, 0}, {1, 0, 0}, 5.0f};  // bent planes far away
  EXPECT_NEAR(joint_zone_volume(m.positions, m.indices, all_triangles(m), z), analyze_topology(m).signed_volume, 1e-9);
}

TEST(JointZone, AWedgeOfACylinderTakesTheVolumeBetweenItsPlanes) {
  // Planes tilted ±30° about Z through points 0.1 m either side: for a straight cylinder the
  // volume between two planes is the ring area times the axial distance between their
  // crossings of the axis (the tilts cancel): centre to plane along the axis 0.1 / cos 30°.
  const Mesh m = cylinder_mesh();
  const float s = 0.5f, c = std::sqrt(3.0f) / 2;  // sin, cos 30°
  const JointZone z{{0.3f, 0, 0}, {-c, s, 0}, {c, s, 0}, 0.1f};
  EXPECT_NEAR(joint_zone_volume(m.positions, m.indices, all_triangles(m), z), kRingArea * 2 * 0.1 / c, 1e-6);
}

TEST(JointZone, SectionAreasOfACylinder) {
  const Mesh m = cylinder_mesh();
  const auto tris = all_triangles(m);
  auto a = section_area(m.positions, m.indices, tris, {0.305f, 0, 0}, {1, 0, 0});
  ASSERT_TRUE(a);
  EXPECT_NEAR(*a, kRingArea, 1e-9);
  // An oblique cut is an ellipse: the ring area over the cosine of the tilt (a 48-gon's
  // ellipse-like section, so within a fraction of a percent).
  const double tilt = 40 * kPi / 180;
  auto b =
      section_area(m.positions, m.indices, tris, {0.3f, 0.01f, 0}, {float(std::cos(tilt)), float(std::sin(tilt)), 0});
  ASSERT_TRUE(b);
  EXPECT_NEAR(*b / (kRingArea / std::cos(tilt)), 1.0, 0.005);
  EXPECT_FALSE(section_area(m.positions, m.indices, tris, {0.3f, 0.2f, 0}, {1, 0, 0}));  // outside the loop
  EXPECT_FALSE(section_area(m.positions, m.indices, tris, {0.9f, 0, 0}, {1, 0, 0}));     // past the end
}

TEST(JointZone, ZoneSectionsOfACylinder) {
  const Mesh m = cylinder_mesh();
  const auto tris = all_triangles(m);
  const JointZone z{{0.3f, 0, 0}, {-1, 0, 0}, {1, 0, 0}, 0.1f};
  for (const auto& [point, normal] : joint_zone_stations(z))
    EXPECT_NEAR(joint_zone_section_area(m.positions, m.indices, tris, z, point, normal), kRingArea, 1e-9);
  // Oblique: the ring area over the cosine of the tilt (the zone's planes are beyond it).
  const double tilt = 40 * kPi / 180;
  const glm::vec3 n{float(std::cos(tilt)), float(std::sin(tilt)), 0};
  EXPECT_NEAR(
      joint_zone_section_area(m.positions, m.indices, tris, z, {0.3f, 0.01f, 0}, n) / (kRingArea / std::cos(tilt)), 1.0,
      0.005);
  // Lengthwise through the axis, the zone clips the cut to its 0.2 m: a 0.1 m × 0.2 m rectangle.
  EXPECT_NEAR(joint_zone_section_area(m.positions, m.indices, tris, z, {0.3f, 0, 0}, {0, 1, 0}), 0.1 * 0.2, 1e-7);
  // A wedge (planes tilted ±30° about Z): in the plane y = 0 (which holds the hinge axis Z) the
  // zone is |x − 0.3| ≤ 0.1 / cos 30°, across the cylinder's 0.1 m.
  const float s = 0.5f, c = std::sqrt(3.0f) / 2;
  const JointZone w{{0.3f, 0, 0}, {-c, s, 0}, {c, s, 0}, 0.1f};
  EXPECT_NEAR(joint_zone_section_area(m.positions, m.indices, tris, w, {0.3f, 0, 0}, {0, 1, 0}), 0.1 * 2 * 0.1 / c,
              1e-7);
}

TEST(JointZone, LinearBlendSkinningLosesVolumeAtTheBentElbow) {
  const rig::Skeleton s = testing::two_bone_skeleton();
  const Mesh rest = cylinder_mesh();
  std::vector<rig::RigidTransform> rest_w(2), w(2);
  rig::forward_kinematics(s, s.zero_pose(), rest_w);
  auto skinner = baselines::BaselineSkinner::create(s, rest_w, rest,
                                                    baselines::weights_from_links(s, rest_w, rest.positions, 0.08f));
  ASSERT_TRUE(skinner);
  const auto tris = all_triangles(rest);
  const JointZone rest_zone{{0.3f, 0, 0}, {-1, 0, 0}, {1, 0, 0}, 0.1f};
  const double v0 = joint_zone_volume(rest.positions, rest.indices, tris, rest_zone);
  rig::Pose p = s.zero_pose();
  p.dof_rad[0] = float(150 * kPi / 180);
  rig::forward_kinematics(s, p, w);
  skinner->set_pose(w);
  JointZone bent = rest_zone;
  bent.distal_dir = w[1].rotation * glm::vec3(1, 0, 0);
  std::vector<glm::vec3> out(skinner->vertex_count());
  auto change = [&](baselines::SkinningMethod m) {
    skinner->deform(m, out);
    return joint_zone_volume(out, rest.indices, tris, bent) / v0 - 1;
  };
  const double lbs = change(baselines::SkinningMethod::lbs);
  const double dqs = change(baselines::SkinningMethod::dqs);
  const double cor = change(baselines::SkinningMethod::cor);
  std::printf("joint zone at 150 deg: lbs %+.1f%%, dqs %+.1f%%, cor %+.1f%%\n", 100 * lbs, 100 * dqs, 100 * cor);
  EXPECT_LT(lbs, -0.10);
  EXPECT_GT(dqs, lbs);
  EXPECT_GT(cor, lbs);
}

}  // namespace
}  // namespace mimic::avatar::joint_zone_test
