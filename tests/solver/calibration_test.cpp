#include "mimic/solver/calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "synthetic_sensors.h"

namespace mimic::solver::calibration_test {
namespace {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;

// A wearer 8 % taller than the default skeleton, standing in a T-pose with the arms 8° low (as
// people do), turned 30° to the left.
struct Wearer {
  Skeleton skeleton;
  Pose pose;
  Wearer(float scale = 1.08f, float heading_deg = 30.0f) {
    auto desc = rig::default_skeleton_desc();
    for (auto& j : desc.joints) j.offset_m *= scale, j.tip_m *= scale;
    skeleton = *Skeleton::build(desc);
    pose = skeleton.zero_pose();
    pose.root_orientation = glm::angleAxis(glm::radians(heading_deg), glm::vec3(0, 1, 0));
    pose.root_position_m = {0.5f, rig::standing_root_height_m(skeleton), -1.0f};
    pose.dof_rad[skeleton.find_dof("l_shoulder_abduction")] = glm::radians(-8.0f);
    pose.dof_rad[skeleton.find_dof("r_shoulder_abduction")] = glm::radians(-8.0f);
  }
};

std::vector<devices::SensorSample> capture(const Wearer& w, const std::vector<SensorMount>& mounts, int ticks,
                                           float noise_m, float noise_rad, float sway_m = 0) {
  std::mt19937_64 rng(42);
  std::vector<devices::SensorSample> all, tick;
  for (int k = 0; k < ticks; ++k) {
    Pose p = w.pose;
    p.root_position_m.x += sway_m * std::sin(0.1f * static_cast<float>(k));
    testing::sense(w.skeleton, p, mounts, tick, &rng, noise_m, noise_rad, 0.01 * k);
    all.insert(all.end(), tick.begin(), tick.end());
  }
  return all;
}

float angle_deg(glm::quat a, glm::quat b) {
  const glm::quat d = a * glm::conjugate(b);
  return glm::degrees(2.0f * std::asin(std::min(1.0f, glm::length(glm::vec3(d.x, d.y, d.z)))));
}

TEST(Calibration, RecoversKnownOffsetsFromASimulatedTPose) {
  for (const char* layout_name : {"6", "11", "3"}) {
    const Wearer w;
    const auto layout = *standard_layout(layout_name, w.skeleton);
    const auto mounts = testing::mounts_for(layout, glm::radians(40.0f), 17);  // straps askew by up to 40°
    const auto samples = capture(w, mounts, 100, 0.001f, glm::radians(0.5f));
    auto cal = calibrate(rig::default_skeleton_desc(), layout, samples);
    ASSERT_TRUE(cal) << cal.error().what();
    ASSERT_EQ(cal->sensors.size(), mounts.size());
    EXPECT_NEAR(cal->heading_deg, 30.0f, 1.0f) << layout_name;
    EXPECT_NEAR(cal->height_m, 1.08f * 1.67f, 0.06f) << layout_name;
    for (size_t i = 0; i < mounts.size(); ++i) {
      EXPECT_EQ(cal->sensors[i].segment, mounts[i].segment);
      EXPECT_LT(angle_deg(cal->sensors[i].segment_from_sensor.rotation, mounts[i].segment_from_sensor.rotation), 3.0f)
          << layout_name << " " << cal->sensors[i].name;
      EXPECT_LT(
          glm::length(cal->sensors[i].segment_from_sensor.translation - mounts[i].segment_from_sensor.translation),
          0.03f)
          << layout_name << " " << cal->sensors[i].name;
    }
    // The fitted skeleton has the wearer's limb lengths (within a centimetre or two).
    const Skeleton fitted = *Skeleton::build(cal->skeleton);
    const auto truth = rig::measure_proportions(w.skeleton), got = rig::measure_proportions(fitted);
    EXPECT_NEAR(got.upper_arm_m + got.forearm_m, truth.upper_arm_m + truth.forearm_m, 0.02f) << layout_name;
    if (std::string(layout_name) != "3") {
      EXPECT_NEAR(got.thigh_m + got.shin_m, truth.thigh_m + truth.shin_m, 0.02f);
    }
  }
}

// A wearer leaning back 10° from the lower back: the upright trunk the fit prefers cannot
// reach the head and hands together, and with free elbows it bent the arms to make up the
// difference, turning the hands' straps by 8° and their wrists 12 mm off. Arms held straight
// (as the stand-still asks) the fit leans the trunk instead.
TEST(Calibration, TrunkLeaningBackLeavesTheArmsStraight) {
  Wearer w;
  w.pose.dof_rad[w.skeleton.find_dof("spine_lower_flexion")] = glm::radians(-10.0f);
  const auto layout = *standard_layout("6", w.skeleton);
  const auto mounts = testing::mounts_for(layout, glm::radians(20.0f), 5);
  const auto samples = capture(w, mounts, 100, 0.001f, glm::radians(0.5f));
  auto cal = calibrate(rig::default_skeleton_desc(), layout, samples);
  ASSERT_TRUE(cal) << cal.error().what();
  for (size_t i = 0; i < mounts.size(); ++i) {
    if (cal->sensors[i].segment.find("wrist") == std::string::npos) continue;
    const float turned =
        angle_deg(cal->sensors[i].segment_from_sensor.rotation, mounts[i].segment_from_sensor.rotation);
    const float moved = glm::length(cal->sensors[i].segment_from_sensor.inverse().translation -
                                    mounts[i].segment_from_sensor.inverse().translation);
    std::printf("  %s: strap turned %.2f deg, wrist %.1f mm off\n", cal->sensors[i].name.c_str(), turned, 1000 * moved);
    EXPECT_LT(turned, 6.0f) << cal->sensors[i].name;
    EXPECT_LT(moved, 0.009f) << cal->sensors[i].name;
  }
}

// Calibrated on the stand-still, the solver puts the wearer's joints back where they are.
TEST(Calibration, CalibratedSolverReproducesTheStandingPose) {
  const Wearer w(0.95f, -60.0f);
  const auto layout = *standard_layout("11", w.skeleton);
  const auto mounts = testing::mounts_for(layout, glm::radians(30.0f), 3);
  const auto samples = capture(w, mounts, 50, 0.0f, 0.0f);
  auto cal = calibrate(rig::default_skeleton_desc(), layout, samples);
  ASSERT_TRUE(cal) << cal.error().what();
  auto model = make_solver_model(*cal);
  ASSERT_TRUE(model) << model.error().what();
  SolverContext ctx(*model);
  Pose solved = model->skeleton().zero_pose();
  std::vector<devices::SensorSample> one(samples.end() - static_cast<long>(mounts.size()), samples.end());
  for (int k = 0; k < 5; ++k) {
    SolveJob job{&*model, one, &ctx, &solved};
    ASSERT_TRUE(job.Run());
  }
  std::vector<RigidTransform> ws(model->skeleton().joint_count()), wt(w.skeleton.joint_count());
  forward_kinematics(model->skeleton(), solved, ws);
  forward_kinematics(w.skeleton, w.pose, wt);
  for (const char* j : {"pelvis", "head", "l_wrist", "r_wrist", "l_ankle", "r_ankle", "r_knee"}) {
    EXPECT_LT(glm::length(ws[model->skeleton().find_joint(j)].translation - wt[w.skeleton.find_joint(j)].translation),
              0.02f)
        << j;
  }
  // Where the elbow sits along the arm a stand-still cannot show (anthropometric split).
  EXPECT_LT(glm::length(ws[model->skeleton().find_joint("l_elbow")].translation -
                        wt[w.skeleton.find_joint("l_elbow")].translation),
            0.04f);
}

TEST(Calibration, RefusesAMissingSensorNamingIt) {
  const Wearer w;
  const auto layout = *standard_layout("6", w.skeleton);
  auto mounts = testing::mounts_for(layout, 0.0f, 1);
  mounts.erase(mounts.begin() + 4);  // l_foot unplugged
  const auto samples = capture(w, mounts, 50, 0.0f, 0.0f);
  auto cal = calibrate(rig::default_skeleton_desc(), layout, samples);
  ASSERT_FALSE(cal);
  EXPECT_NE(cal.error().message.find("l_foot"), std::string::npos) << cal.error().message;
  EXPECT_NE(cal.error().message.find("no data"), std::string::npos);
}

TEST(Calibration, RefusesAWearerWhoMoves) {
  const Wearer w;
  const auto layout = *standard_layout("3", w.skeleton);
  const auto mounts = testing::mounts_for(layout, 0.0f, 1);
  const auto samples = capture(w, mounts, 100, 0.0f, 0.0f, 0.05f);  // swaying 5 cm
  auto cal = calibrate(rig::default_skeleton_desc(), layout, samples);
  ASSERT_FALSE(cal);
  EXPECT_NE(cal.error().message.find("moved"), std::string::npos) << cal.error().message;
  // Noise alone is not motion.
  EXPECT_TRUE(calibrate(rig::default_skeleton_desc(), layout, capture(w, mounts, 100, 0.002f, glm::radians(1.0f))));
}

TEST(Calibration, JsonRoundTrip) {
  const Wearer w;
  const auto layout = *standard_layout("6", w.skeleton);
  const auto mounts = testing::mounts_for(layout, glm::radians(20.0f), 8);
  auto cal = calibrate(rig::default_skeleton_desc(), layout, capture(w, mounts, 20, 0.0f, 0.0f));
  ASSERT_TRUE(cal);
  const std::string text = calibration_to_json(*cal);
  auto back = calibration_from_json(text);
  ASSERT_TRUE(back) << back.error().what();
  ASSERT_EQ(back->skeleton.joints.size(), cal->skeleton.joints.size());
  for (size_t j = 0; j < cal->skeleton.joints.size(); ++j) {
    const auto &a = cal->skeleton.joints[j], &b = back->skeleton.joints[j];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.parent, b.parent);
    EXPECT_LT(glm::length(a.offset_m - b.offset_m), 1e-6f);
    EXPECT_LT(glm::length(a.tip_m - b.tip_m), 1e-6f);
    ASSERT_EQ(a.dofs.size(), b.dofs.size());
    for (size_t d = 0; d < a.dofs.size(); ++d) {
      EXPECT_EQ(a.dofs[d].name, b.dofs[d].name);
      EXPECT_NEAR(a.dofs[d].min_rad, b.dofs[d].min_rad, 1e-6f);
      EXPECT_NEAR(a.dofs[d].max_rad, b.dofs[d].max_rad, 1e-6f);
    }
  }
  ASSERT_EQ(back->sensors.size(), cal->sensors.size());
  for (size_t i = 0; i < cal->sensors.size(); ++i) {
    EXPECT_LT(
        glm::length(back->sensors[i].segment_from_sensor.translation - cal->sensors[i].segment_from_sensor.translation),
        1e-6f);
    EXPECT_LT(angle_deg(back->sensors[i].segment_from_sensor.rotation, cal->sensors[i].segment_from_sensor.rotation),
              1e-3f);
  }
  EXPECT_FLOAT_EQ(back->standing_root_y_m, cal->standing_root_y_m);
  EXPECT_FLOAT_EQ(back->floor_y_m, cal->floor_y_m);
  EXPECT_NEAR(cal->standing_root_y_m, w.pose.root_position_m.y, 0.05f);
  EXPECT_TRUE(make_solver_model(*back));
}

TEST(Calibration, MalformedJsonGivesAClearError) {
  EXPECT_EQ(calibration_from_json("{").error().code, Errc::parse_error);
  EXPECT_NE(calibration_from_json("{\"format\":\"other\"}").error().message.find("format"), std::string::npos);
  const Wearer w;
  const auto layout = *standard_layout("3", w.skeleton);
  auto cal = calibrate(rig::default_skeleton_desc(), layout, capture(w, testing::mounts_for(layout, 0, 1), 10, 0, 0));
  ASSERT_TRUE(cal);
  std::string text = calibration_to_json(*cal);
  const auto at = text.find("\"rotation_wxyz\"");
  text.replace(at, 15, "\"rotation_xyzw\"");
  auto bad = calibration_from_json(text);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("rotation_wxyz"), std::string::npos) << bad.error().message;

  // Members of the wrong type or beyond a float's range are errors, never exceptions (found by
  // fuzz/calibration_fuzz.cpp: a numeric "format" used to throw).
  const std::string good = calibration_to_json(*cal);
  auto with = [&](const std::string& from, const std::string& to) {
    std::string t = good;
    const auto pos = t.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    if (pos != std::string::npos) t.replace(pos, from.size(), to);
    return calibration_from_json(t);
  };
  EXPECT_FALSE(with("\"format\": \"mimic-calibration\"", "\"format\": 13"));
  EXPECT_FALSE(with("\"version\": 1", "\"version\": \"1\""));
  EXPECT_FALSE(with("\"pose\": \"tpose\"", "\"pose\": []"));
  auto huge = with("\"rotation_wxyz\": [", "\"rotation_wxyz\": [1e300, ");
  ASSERT_FALSE(huge);
  EXPECT_NE(huge.error().message.find("rotation_wxyz"), std::string::npos) << huge.error().message;
  EXPECT_TRUE(with("\"samples\": ", "\"samples\": 1e30, \"ignored\": "));  // statistics only: ignored
}

}  // namespace
}  // namespace mimic::solver::calibration_test

namespace mimic::solver::calibration_test {
namespace {

TEST(TrackingSkeleton, UnmarkedJointsFollowTheMotionCaptureConvention) {
  const rig::SkeletonDesc base = rig::default_skeleton_desc();
  const Skeleton s = *Skeleton::build(tracking_skeleton_desc(base));
  const Skeleton d = *Skeleton::build(base);
  ASSERT_EQ(s.joint_count(), d.joint_count());
  ASSERT_EQ(s.dof_count(), d.dof_count());
  for (int i = 0; i < s.dof_count(); ++i) EXPECT_EQ(s.dof(i).name, d.dof(i).name);
  for (const char* at_parent : {"spine_lower", "neck", "l_clavicle", "r_clavicle"})
    EXPECT_EQ(glm::length(s.offset_m(s.find_joint(at_parent))), 0.0f) << at_parent;
  // Limbs untouched in length where a stand-still measures them, hips below the root.
  const float leg = glm::length(s.offset_m(s.find_joint("l_knee"))) + glm::length(s.offset_m(s.find_joint("l_ankle")));
  EXPECT_NEAR(leg, glm::length(d.offset_m(d.find_joint("l_knee"))) + glm::length(d.offset_m(d.find_joint("l_ankle"))),
              1e-5f);
  EXPECT_LT(s.offset_m(s.find_joint("l_hip")).y, -0.08f);
  // The solver accepts it (straight limbs, bend axes across them).
  EXPECT_TRUE(SolverModel::create(s, {}));
}

// One sensor per segment, each at the middle of the wearer's own link, the calibration told only
// "the middle": the joints come out where the wearer's are, though every link differs from the
// tracking skeleton's.
void mid_link_calibration_places_the_wearers_joints(CalibrationPose calibration_pose) {
  auto desc = tracking_skeleton_desc();
  for (auto& j : desc.joints) {  // a wearer 6 % taller, long-legged, with a short neck
    const float k = j.name.find("knee") != std::string::npos || j.name.find("ankle") != std::string::npos ? 1.12f
                    : j.name == "neck_upper" || j.name == "head"                                          ? 0.85f
                                                                                                          : 1.06f;
    j.offset_m *= k;
    j.tip_m *= k;
  }
  for (auto& j : desc.joints)  // tips follow the links they lie along
    for (const auto& c : desc.joints)
      if (c.parent == j.name && glm::length(c.offset_m) > 1e-4f &&
          std::abs(glm::dot(glm::normalize(c.offset_m), glm::normalize(j.tip_m)) - 1.0f) < 1e-3f)
        j.tip_m = c.offset_m;
  Wearer w(1.0f, 20.0f);
  w.skeleton = *Skeleton::build(desc);
  w.pose = w.skeleton.zero_pose();
  w.pose.root_orientation = glm::angleAxis(glm::radians(20.0f), glm::vec3(0, 1, 0));
  w.pose.root_position_m = {0.3f, rig::standing_root_height_m(w.skeleton), 0.7f};
  if (calibration_pose == CalibrationPose::n_pose)
    for (const char* d : {"l_shoulder_abduction", "r_shoulder_abduction"})
      w.pose.dof_rad[w.skeleton.find_dof(d)] = glm::radians(-80.0f);
  const auto worn = *standard_layout("all", w.skeleton);  // where the straps really are
  const auto told = *standard_layout("all", *Skeleton::build(tracking_skeleton_desc()));
  const auto mounts = testing::mounts_for(worn, glm::radians(15.0f), 5);
  CalibrationOptions opt;
  opt.pose = calibration_pose;
  auto cal = calibrate(tracking_skeleton_desc(), told, capture(w, mounts, 60, 0.0005f, glm::radians(0.2f)), opt);
  ASSERT_TRUE(cal) << cal.error().what();
  auto model = make_solver_model(*cal);
  ASSERT_TRUE(model) << model.error().what();
  SolverContext ctx(*model);
  std::vector<devices::SensorSample> tick;
  testing::sense(w.skeleton, w.pose, mounts, tick);
  Pose solved = model->skeleton().zero_pose();
  for (int k = 0; k < 8; ++k) {
    SolveJob job{&*model, tick, &ctx, &solved};
    ASSERT_TRUE(job.Run());
  }
  std::vector<RigidTransform> ws(model->skeleton().joint_count()), wt(w.skeleton.joint_count());
  forward_kinematics(model->skeleton(), solved, ws);
  forward_kinematics(w.skeleton, w.pose, wt);
  for (int j = 0; j < w.skeleton.joint_count(); ++j) {
    if (w.skeleton.joint_name(j).find("toes") != std::string::npos) continue;
    // The root is placed from the hips with the skeleton's hip offset, and an error there
    // alternates along the spine's mid-link recurrence: the neck's two links take it twice.
    const bool neck = w.skeleton.joint_name(j) == "neck_upper" || w.skeleton.joint_name(j) == "head";
    EXPECT_LT(glm::length(ws[j].translation - wt[j].translation), neck ? 0.025f : 0.01f) << w.skeleton.joint_name(j);
  }
}

TEST(Calibration, MidLinkSensorsMarkTheWearersJoints) {
  mid_link_calibration_places_the_wearers_joints(CalibrationPose::t_pose);
}

TEST(Calibration, MidLinkSensorsMarkTheWearersJointsInAnNPose) {
  mid_link_calibration_places_the_wearers_joints(CalibrationPose::n_pose);
}

}  // namespace
}  // namespace mimic::solver::calibration_test
