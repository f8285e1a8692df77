#include <gtest/gtest.h>

#include <glm/gtx/norm.hpp>
#include <random>

#include "mimic/rig/skeleton.h"

namespace mimic::rig::skeleton_test {
namespace {

Skeleton default_skeleton() {
  auto s = Skeleton::build(default_skeleton_desc());
  EXPECT_TRUE(s) << s.error().what();
  return *s;
}

glm::vec3 joint_pos(const Skeleton& s, const Pose& p, const char* name) {
  std::vector<RigidTransform> w(s.joint_count());
  forward_kinematics(s, p, w);
  return w[s.find_joint(name)].translation;
}

TEST(Skeleton, DefaultHasTheRequiredJointsAndDofs) {
  const Skeleton s = default_skeleton();
  for (const char* j : {"pelvis", "spine_lower", "spine_mid", "spine_upper", "neck", "head", "l_clavicle", "r_clavicle",
                        "l_shoulder", "l_elbow", "l_wrist", "l_hip", "l_knee", "l_ankle", "l_toes", "r_toes"})
    EXPECT_GE(s.find_joint(j), 0) << j;
  for (const char* d : {"l_elbow_flexion", "r_shoulder_abduction", "l_forearm_twist", "l_shoulder_flexion",
                        "l_shoulder_twist", "r_hip_rotation", "l_knee_flexion"})
    EXPECT_GE(s.find_dof(d), 0) << d;
  EXPECT_EQ(s.dof_begin(s.find_joint("l_shoulder")) + 3, s.dof_end(s.find_joint("l_shoulder")));
  EXPECT_EQ(s.dof_begin(s.find_joint("l_hip")) + 3, s.dof_end(s.find_joint("l_hip")));
  for (int j = 1; j < s.joint_count(); ++j) EXPECT_LT(s.parent(j), j) << "parents come first";
}

TEST(Skeleton, ZeroPoseIsATPoseFacingPlusZ) {
  const Skeleton s = default_skeleton();
  const Pose p = s.zero_pose();
  const glm::vec3 ls = joint_pos(s, p, "l_shoulder"), le = joint_pos(s, p, "l_elbow");
  const glm::vec3 lw = joint_pos(s, p, "l_wrist");
  EXPECT_NEAR(le.y, ls.y, 1e-6);
  EXPECT_GT(le.x, ls.x);  // left is +X
  EXPECT_GT(lw.x, le.x);
  EXPECT_GT(joint_pos(s, p, "l_toes").z, joint_pos(s, p, "l_ankle").z);  // feet point +Z
}

TEST(Skeleton, ElbowFlexionBringsTheForearmForward) {
  const Skeleton s = default_skeleton();
  Pose p = s.zero_pose();
  p.dof_rad[s.find_dof("l_elbow_flexion")] = glm::radians(90.0f);
  p.dof_rad[s.find_dof("r_elbow_flexion")] = glm::radians(90.0f);
  const glm::vec3 le = joint_pos(s, p, "l_elbow"), lw = joint_pos(s, p, "l_wrist");
  const glm::vec3 re = joint_pos(s, p, "r_elbow"), rw = joint_pos(s, p, "r_wrist");
  EXPECT_NEAR(lw.z - le.z, 0.226f, 1e-4);
  EXPECT_NEAR(rw.z - re.z, 0.226f, 1e-4);
}

TEST(Skeleton, EqualAnglesGiveMirrorImagePostures) {
  const Skeleton s = default_skeleton();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Pose p = s.zero_pose();
  for (int i = 0; i < s.dof_count(); ++i) {
    const std::string& n = s.dof(i).name;
    if (n.rfind("l_", 0) == 0) {
      p.dof_rad[i] = u(rng);
      p.dof_rad[s.find_dof("r_" + n.substr(2))] = p.dof_rad[i];
    }
  }
  std::vector<RigidTransform> w(s.joint_count());
  forward_kinematics(s, p, w);
  for (int j = 0; j < s.joint_count(); ++j) {
    const std::string& n = s.joint_name(j);
    if (n.rfind("l_", 0) != 0) continue;
    const glm::vec3 l = w[j].translation, r = w[s.find_joint("r_" + n.substr(2))].translation;
    EXPECT_NEAR(l.x, -r.x, 1e-5) << n;
    EXPECT_NEAR(l.y, r.y, 1e-5) << n;
    EXPECT_NEAR(l.z, r.z, 1e-5) << n;
  }
}

TEST(Skeleton, RejectsMalformedDescriptions) {
  SkeletonDesc d = default_skeleton_desc();
  d.joints[3].parent = "nowhere";
  auto r = Skeleton::build(d);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("nowhere"), std::string::npos);

  d = default_skeleton_desc();
  d.joints.push_back(d.joints[2]);
  EXPECT_FALSE(Skeleton::build(d));

  d = default_skeleton_desc();
  d.joints[4].dofs[0].min_rad = 1.0f;  // rest 0 below min
  EXPECT_FALSE(Skeleton::build(d));
}

TEST(Skeleton, ProportionsRoundTrip) {
  SkeletonDesc d = default_skeleton_desc();
  Proportions p;
  p.thigh_m = 0.5f;
  p.upper_arm_m = 0.3f;
  p.shoulder_width_m = 0.42f;
  apply_proportions(d, p);
  auto s = Skeleton::build(d);
  ASSERT_TRUE(s);
  const Proportions m = measure_proportions(*s);
  EXPECT_NEAR(m.thigh_m, 0.5f, 1e-5);
  EXPECT_NEAR(m.upper_arm_m, 0.3f, 1e-5);
  EXPECT_NEAR(m.shoulder_width_m, 0.42f, 1e-4);
  EXPECT_NEAR(glm::length(s->tip_m(s->find_joint("l_hip"))), 0.5f, 1e-5) << "the link follows";
}

TEST(Skeleton, DefaultStandsAbout167Tall) {
  const Skeleton s = default_skeleton();
  const float root_h = standing_root_height_m(s);
  EXPECT_NEAR(root_h, 0.89f, 0.02f);
  Pose p = s.zero_pose();
  p.root_position_m.y = root_h;
  std::vector<RigidTransform> w(s.joint_count());
  forward_kinematics(s, p, w);
  const int head = s.find_joint("head");
  EXPECT_NEAR(w[head].apply(s.tip_m(head)).y, 1.666f, 0.02f);
}

}  // namespace
}  // namespace mimic::rig::skeleton_test
