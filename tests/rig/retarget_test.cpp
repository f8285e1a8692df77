#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "mimic/rig/retarget.h"
#include "test_data.h"

namespace mimic::rig::retarget_test {
namespace {

struct ClipError {
  double max_m = 0;
  std::string where;
};

// Largest distance between Mimic's joint centres and the clip's own joints, over all frames.
ClipError max_joint_error(const BvhClip& clip, const RetargetedClip& r, int stride = 1) {
  std::vector<RigidTransform> wm(r.skeleton.joint_count()), wb(clip.joints.size());
  ClipError e;
  for (int f = 0; f < clip.frame_count; f += stride) {
    forward_kinematics(r.skeleton, r.poses[f], wm);
    bvh_forward_kinematics(clip, f, wb);
    for (int j = 0; j < r.skeleton.joint_count(); ++j) {
      const double d = glm::length(wm[j].translation - wb[r.bvh_joint[j]].translation);
      if (d > e.max_m) {
        e.max_m = d;
        e.where = r.skeleton.joint_name(j) + " frame " + std::to_string(f);
      }
    }
  }
  return e;
}

TEST(Retarget, EverySharedClipMatchesItsOwnJointPositionsWithin1cm) {
  for (const char* id : test::kShared_clips) {
    auto clip = load_bvh(test::clip_path(id));
    ASSERT_TRUE(clip) << clip.error().what();
    auto r = retarget_bvh(*clip);
    ASSERT_TRUE(r) << r.error().what();
    ASSERT_EQ(static_cast<int>(r->poses.size()), clip->frame_count);
    EXPECT_DOUBLE_EQ(r->frame_time_s, clip->frame_time_s);
    const ClipError e = max_joint_error(*clip, *r);
    std::printf("  %s: %d frames, max joint error %.3f mm (%s)\n", id, clip->frame_count, e.max_m * 1000,
                e.where.c_str());
    EXPECT_LT(e.max_m, 0.01) << id << " at " << e.where;
  }
}

TEST(Retarget, FittedSkeletonKeepsThePerformersProportions) {
  auto clip = load_bvh(test::clip_path("07_01"));
  ASSERT_TRUE(clip);
  auto r = retarget_bvh(*clip);
  ASSERT_TRUE(r);
  const Proportions p = measure_proportions(r->skeleton);
  // Data README, subject 7 (BVH units): thigh 6.92, shin 7.41, upper arm 4.97, forearm 3.36.
  const double u = kCmuMetresPerUnit;
  EXPECT_NEAR(p.thigh_m, 6.92 * u, 0.01 * u);
  EXPECT_NEAR(p.shin_m, 7.41 * u, 0.01 * u);
  EXPECT_NEAR(p.upper_arm_m, 4.97 * u, 0.01 * u);
  EXPECT_NEAR(p.forearm_m, 3.36 * u, 0.01 * u);
  // The zero posture stands straight: thighs and shins along −Y, arms along ±X.
  const Skeleton& s = r->skeleton;
  EXPECT_LT(glm::length(glm::normalize(s.offset_m(s.find_joint("l_knee"))) - glm::vec3(0, -1, 0)), 1e-5f);
  EXPECT_LT(glm::length(glm::normalize(s.offset_m(s.find_joint("r_ankle"))) - glm::vec3(0, -1, 0)), 1e-5f);
  EXPECT_LT(glm::length(glm::normalize(s.offset_m(s.find_joint("l_wrist"))) - glm::vec3(1, 0, 0)), 1e-5f);
  // README: T-pose hip height 16.63 units. Mimic's zero posture pitches the foot down more
  // than the performer's rest foot, so standing on the toe tip the pelvis sits a little higher.
  EXPECT_NEAR(standing_root_height_m(s), 16.63 * u, 0.05);
}

TEST(Retarget, TPoseFrameGivesNearZeroLimbAngles) {
  auto clip = load_bvh(test::clip_path("02_04"));
  ASSERT_TRUE(clip);
  auto r = retarget_bvh(*clip);
  ASSERT_TRUE(r);
  const Pose& t = r->poses[0];
  const Skeleton& s = r->skeleton;
  for (const char* d : {"l_knee_flexion", "r_knee_flexion", "l_hip_flexion", "l_elbow_flexion", "r_elbow_flexion"})
    EXPECT_NEAR(glm::degrees(t.dof_rad[s.find_dof(d)]), 0.0, 2.0) << d;
  // Arms 8° below horizontal in the T-pose.
  EXPECT_NEAR(glm::degrees(t.dof_rad[s.find_dof("l_shoulder_abduction")]), -8.0, 2.0);
  EXPECT_NEAR(glm::degrees(t.dof_rad[s.find_dof("r_shoulder_abduction")]), -8.0, 2.0);
}

// Angle between a segment's up axis and the world's.
double tilt_deg(const RigidTransform& world_from_segment) {
  const glm::vec3 up = world_from_segment.rotation * glm::vec3(0, 1, 0);
  return glm::degrees(std::acos(std::clamp(double(up.y), -1.0, 1.0)));
}

TEST(Retarget, CmuClipsAreCharacterisedOnTheirFrameZeroTPose) {
  for (const char* id : test::kShared_clips) {
    auto clip = load_bvh(test::clip_path(id));
    ASSERT_TRUE(clip);
    auto r = retarget_bvh(*clip);
    ASSERT_TRUE(r);
    EXPECT_TRUE(r->characterised_on_t_pose) << id;
    std::vector<RigidTransform> w(r->skeleton.joint_count());
    forward_kinematics(r->skeleton, r->poses[0], w);
    // Head level, feet flat, facing where the pelvis faces.
    const glm::vec3 facing = w[0].rotation * glm::vec3(0, 0, 1);
    for (const char* j : {"head", "l_ankle", "r_ankle"}) {
      const RigidTransform& t = w[r->skeleton.find_joint(j)];
      EXPECT_LT(tilt_deg(t), 0.5) << id << " " << j;
      const glm::vec3 f = t.rotation * glm::vec3(0, 0, 1);
      EXPECT_GT(glm::dot(glm::normalize(glm::vec2(f.x, f.z)), glm::normalize(glm::vec2(facing.x, facing.z))),
                std::cos(glm::radians(3.0)))
          << id << " " << j;
    }
  }
}

TEST(Retarget, PlantedFeetStandFlat) {
  // Walking: where a foot rests on the floor (slower than 10 cm/s, within 3 cm of its lowest),
  // its sole is level. Aligned at the clip's rest pose they stood 17–24° on their edges.
  for (const char* id : {"02_04", "07_01"}) {
    auto clip = load_bvh(test::clip_path(id));
    ASSERT_TRUE(clip);
    auto r = retarget_bvh(*clip);
    ASSERT_TRUE(r);
    const Skeleton& s = r->skeleton;
    for (const char* foot : {"l_ankle", "r_ankle"}) {
      const int j = s.find_joint(foot);
      std::vector<RigidTransform> w(s.joint_count());
      std::vector<RigidTransform> at(r->poses.size());
      double lowest = 1e9;
      for (size_t f = 0; f < r->poses.size(); ++f) {
        forward_kinematics(s, r->poses[f], w);
        at[f] = w[j];
        if (f > 0) lowest = std::min(lowest, double(at[f].translation.y));  // frame 0: the T-pose
      }
      double sum = 0;
      int planted = 0;
      for (size_t f = 2; f < at.size(); ++f) {
        const double speed = glm::length(at[f].translation - at[f - 1].translation) / r->frame_time_s;
        if (speed > 0.1 || at[f].translation.y > lowest + 0.03) continue;
        sum += tilt_deg(at[f]);
        ++planted;
      }
      ASSERT_GT(planted, 5) << id << " " << foot;
      std::printf("  %s %s: %.1f deg from level over %d planted frames\n", id, foot, sum / planted, planted);
      EXPECT_LT(sum / planted, 8.0) << id << " " << foot << " over " << planted << " planted frames";
    }
  }
}

TEST(Retarget, ClipsWithoutATPoseAlignAtTheRestPose) {
  auto clip = load_bvh(test::clip_path("02_04"));
  ASSERT_TRUE(clip);
  // The clip from its second frame: the performer is already moving, arms down.
  clip->values.erase(clip->values.begin(), clip->values.begin() + clip->channel_count);
  --clip->frame_count;
  auto r = retarget_bvh(*clip);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->characterised_on_t_pose);
  EXPECT_LT(max_joint_error(*clip, *r).max_m, 0.01);
}

TEST(Retarget, SequencesHaveNoJumps) {
  // Continuity: consecutive captured frames (120 Hz) never jump; a ±180° flip or a 2π wrap
  // would show as a step of 180° or more. Near gimbal lock (a shoulder hanging straight down,
  // abduction ≈ −90°) flexion and twist legitimately trade off by tens of degrees in a frame,
  // so the bound is loose.
  for (const char* id : {"05_02", "13_26"}) {  // the clips with unwrapped |365|°, |448|° roots
    auto clip = load_bvh(test::clip_path(id));
    ASSERT_TRUE(clip);
    auto r = retarget_bvh(*clip);
    ASSERT_TRUE(r);
    double worst = 0;
    std::string where;
    for (size_t f = 2; f < r->poses.size(); ++f)
      for (int i = 0; i < r->skeleton.dof_count(); ++i) {
        const double d = std::abs(r->poses[f].dof_rad[i] - r->poses[f - 1].dof_rad[i]);
        if (d > worst) {
          worst = d;
          where = r->skeleton.dof(i).name + " frame " + std::to_string(f);
        }
      }
    std::printf("  %s: largest DOF step %.2f deg (%s)\n", id, glm::degrees(worst), where.c_str());
    EXPECT_LT(glm::degrees(worst), 60.0) << id << " " << where;
  }
}

TEST(Retarget, ExportedClipsRetargetBackToTheSamePositions) {
  // CMU clip -> retarget -> write_bvh -> parse -> retarget (Mimic names map to themselves).
  for (const char* id : test::kShared_clips) {
    auto clip = load_bvh(test::clip_path(id));
    ASSERT_TRUE(clip);
    auto r = retarget_bvh(*clip);
    ASSERT_TRUE(r);
    auto text = write_bvh(r->skeleton, r->poses, r->frame_time_s);
    ASSERT_TRUE(text) << text.error().what();
    auto again = parse_bvh(*text, "export.bvh");
    ASSERT_TRUE(again) << again.error().what();
    auto r2 = retarget_bvh(*again);
    ASSERT_TRUE(r2) << r2.error().what();
    ASSERT_EQ(r2->poses.size(), r->poses.size());
    ASSERT_EQ(r2->skeleton.joint_count(), r->skeleton.joint_count());
    std::vector<RigidTransform> w1(r->skeleton.joint_count()), w2(w1.size());
    double worst = 0;
    for (size_t f = 0; f < r->poses.size(); ++f) {
      forward_kinematics(r->skeleton, r->poses[f], w1);
      forward_kinematics(r2->skeleton, r2->poses[f], w2);
      for (size_t j = 0; j < w1.size(); ++j)
        worst = std::max(worst, double(glm::length(w1[j].translation - w2[j].translation)));
    }
    std::printf("  %s round trip: max joint difference %.4f mm over %zu frames\n", id, worst * 1000, r->poses.size());
    EXPECT_LT(worst, 0.001) << id;
    for (int j = 0; j < r->skeleton.joint_count(); ++j)
      EXPECT_LT(glm::length(r->skeleton.offset_m(j) - r2->skeleton.offset_m(j)), 1e-5f)
          << id << " " << r->skeleton.joint_name(j);
  }
}

TEST(Retarget, TransferPoseScalesTheRootToTheOtherBody) {
  auto clip = load_bvh(test::clip_path("13_26"));
  ASSERT_TRUE(clip);
  auto r = retarget_bvh(*clip);
  ASSERT_TRUE(r);
  auto body = Skeleton::build(default_skeleton_desc());
  ASSERT_TRUE(body);
  const Pose& src = r->poses[100];
  const Pose p = transfer_pose(r->skeleton, src, *body);
  const float ratio = standing_root_height_m(*body) / standing_root_height_m(r->skeleton);
  EXPECT_NEAR(p.root_position_m.y, src.root_position_m.y * ratio, 1e-5);
  EXPECT_NEAR(p.root_position_m.x, src.root_position_m.x * ratio, 1e-5);
  for (int i = 0; i < body->dof_count(); ++i)
    EXPECT_EQ(p.dof_rad[i], src.dof_rad[r->skeleton.find_dof(body->dof(i).name)]);
  // The default body's lowest foot joint sits about as high above the floor as the performer's.
  std::vector<RigidTransform> wa(r->skeleton.joint_count()), wb(body->joint_count());
  forward_kinematics(r->skeleton, src, wa);
  forward_kinematics(*body, p, wb);
  const float fa = std::min(wa[r->skeleton.find_joint("l_ankle")].translation.y,
                            wa[r->skeleton.find_joint("r_ankle")].translation.y);
  const float fb =
      std::min(wb[body->find_joint("l_ankle")].translation.y, wb[body->find_joint("r_ankle")].translation.y);
  EXPECT_NEAR(fa, fb, 0.03f);
}

TEST(Retarget, RejectsUnknownSkeletonsAndEmptyClips) {
  auto clip = parse_bvh(
      "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n}\nMOTION\nFrames: 1\nFrame "
      "Time: 0.1\n0 0 0\n",
      "tiny.bvh");
  ASSERT_TRUE(clip);
  auto r = retarget_bvh(*clip);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::unsupported);
  EXPECT_NE(r.error().message.find("LowerBack"), std::string::npos) << r.error().message;
  clip->frame_count = 0;
  clip->values.clear();
  EXPECT_FALSE(retarget_bvh(*clip));
}

TEST(BvhMotion, PlaysTheClipWithInterpolation) {
  auto m = load_bvh_motion(test::clip_path("09_11"));
  ASSERT_TRUE(m) << m.error().what();
  const Motion& motion = **m;
  EXPECT_FALSE(motion.loops());
  EXPECT_NEAR(motion.duration_s(), 165 * 0.0083333, 1e-9);
  auto clip = load_bvh(test::clip_path("09_11"));
  auto r = retarget_bvh(*clip);
  Pose p = motion.skeleton().zero_pose();
  motion.sample(10 * 0.0083333, p);
  for (size_t i = 0; i < p.dof_rad.size(); ++i) EXPECT_NEAR(p.dof_rad[i], r->poses[10].dof_rad[i], 1e-5);
  motion.sample(10.5 * 0.0083333, p);
  for (size_t i = 0; i < p.dof_rad.size(); ++i)
    EXPECT_NEAR(p.dof_rad[i], 0.5f * (r->poses[10].dof_rad[i] + r->poses[11].dof_rad[i]), 1e-5);
  EXPECT_LT(glm::length(p.root_position_m - 0.5f * (r->poses[10].root_position_m + r->poses[11].root_position_m)),
            1e-5f);
  motion.sample(1e9, p);  // clamped to the last frame
  EXPECT_LT(glm::length(p.root_position_m - r->poses.back().root_position_m), 1e-6f);
  motion.sample(-5, p);
  EXPECT_LT(glm::length(p.root_position_m - r->poses.front().root_position_m), 1e-6f);
  EXPECT_FALSE(load_bvh_motion("/nonexistent/clip.bvh"));
}

TEST(BvhMotion, CanDriveAnotherBody) {
  auto body = Skeleton::build(default_skeleton_desc());
  ASSERT_TRUE(body);
  BvhMotionOptions options;
  options.body = &*body;
  auto m = load_bvh_motion(test::clip_path("07_01"), options);
  ASSERT_TRUE(m) << m.error().what();
  EXPECT_EQ((*m)->skeleton().dof_count(), body->dof_count());
  EXPECT_EQ((*m)->skeleton().offset_m(body->find_joint("l_knee")), body->offset_m(body->find_joint("l_knee")));
  auto plain = load_bvh_motion(test::clip_path("07_01"));
  ASSERT_TRUE(plain);
  Pose a = body->zero_pose(), b = (*plain)->skeleton().zero_pose();
  (*m)->sample(1.0, a);
  (*plain)->sample(1.0, b);
  EXPECT_EQ(a.dof_rad, b.dof_rad) << "same joint angles";
  const float ratio = standing_root_height_m(*body) / standing_root_height_m((*plain)->skeleton());
  EXPECT_NEAR(a.root_position_m.y, b.root_position_m.y * ratio, 1e-4f);
}

}  // namespace
}  // namespace mimic::rig::retarget_test
