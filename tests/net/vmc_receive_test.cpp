// Receiving VMC and OSC trackers: Mimic's own VMC output read back over loopback, liblo's
// oscsend (a third-party OSC implementation) as a sender, and malformed input counted by reason.
#include <gtest/gtest.h>

#include <cstdlib>
#include <thread>

#include "mimic/rig/skeleton.h"
#include "mimic/net/vmc.h"
#include "mimic/net/vmc_receive.h"

namespace mimic::net::vmc_receive_test {
namespace {

using Bytes = std::vector<uint8_t>;

bool near(const glm::quat& a, const glm::quat& b, float tol = 1e-4f) {
  return std::fabs(std::fabs(glm::dot(a, b)) - 1.0f) < tol;
}

rig::Skeleton default_skeleton() { return *rig::Skeleton::build(rig::default_skeleton_desc()); }

rig::Pose some_pose(const rig::Skeleton& s) {
  rig::Pose p = s.rest_pose();
  for (size_t d = 0; d < p.dof_rad.size(); ++d) p.dof_rad[d] = 0.3f * std::sin(0.7f * float(d) + 0.2f);
  p.root_position_m = {0.2f, 0.95f, -0.4f};
  p.root_orientation = glm::angleAxis(0.6f, glm::normalize(glm::vec3(0.1f, 1, 0.05f)));
  return p;
}

// An encoded frame's bundles, each as the datagram it is sent as.
void apply_bundles(const Bytes& out, const VmcBundles& b, VmcState& state, VmcReceiveStats& stats) {
  size_t start = 0;
  for (size_t i = 0; i < b.count; ++i) {
    apply_vmc_packet(std::span<const uint8_t>(out.data() + start, b.end[i] - start), 1.0, state, stats);
    start = b.end[i];
  }
}

// What Mimic sends as VMC, read back: every body bone's local rotation, the hips' world
// placement, the frame's end (OK) and stream time.
TEST(VmcReceive, MimicsOwnVmcFramesReadBackExactly) {
  const auto s = default_skeleton();
  const rig::Pose pose = some_pose(s);
  VmcEncoder enc(s);
  Bytes out;
  const VmcBundles b = enc.encode(pose, 2.5, out);
  VmcState state;
  VmcReceiveStats stats;
  apply_bundles(out, b, state, stats);
  EXPECT_EQ(stats.refused_total(), 0u);
  EXPECT_EQ(stats.unknown_bones, 0u);
  EXPECT_EQ(state.frames, 1u);
  EXPECT_DOUBLE_EQ(state.sender_time_s, 2.5);
  const std::span<const float> dofs(pose.dof_rad);
  for (const auto& bone : enc.bones()) {
    const int i = unity_bone_index(bone.unity_name);
    ASSERT_GE(i, 0) << bone.unity_name;
    const TrackedPose& got = state.bones[size_t(i)];
    ASSERT_TRUE(got.present) << bone.unity_name;
    glm::quat want = s.local_rotation(bone.joint, dofs);
    if (bone.fold_joint >= 0) want = want * s.local_rotation(bone.fold_joint, dofs);
    if (s.parent(bone.joint) < 0) {
      want = pose.root_orientation * want;
      EXPECT_NEAR(glm::length(got.position_m - pose.root_position_m), 0.0f, 1e-5f);
    }
    EXPECT_TRUE(near(got.orientation, want)) << bone.unity_name;
  }
}

// Mimic's VMC output turned back into a pose on the same skeleton: every joint where the
// original put it (the neck's split between neck and neck_upper is VMC's one loss).
TEST(VmcReceive, PoseFromVmcRoundTripsMimicsOutput) {
  const auto s = default_skeleton();
  const rig::Pose pose = some_pose(s);
  VmcEncoder enc(s);
  Bytes out;
  const VmcBundles b = enc.encode(pose, 0.0, out);
  VmcState state;
  VmcReceiveStats stats;
  apply_bundles(out, b, state, stats);
  rig::Pose got = s.rest_pose();
  ASSERT_TRUE(pose_from_vmc(state, s, enc.bones(), got));
  std::vector<rig::RigidTransform> want_fk(size_t(s.joint_count())), got_fk(size_t(s.joint_count()));
  rig::forward_kinematics(s, pose, want_fk);
  rig::forward_kinematics(s, got, got_fk);
  for (int j = 0; j < s.joint_count(); ++j) {
    const float err = glm::length(want_fk[size_t(j)].translation - got_fk[size_t(j)].translation);
    const bool above_neck = s.joint_name(j) == "neck_upper" || s.joint_name(j) == "head";
    EXPECT_LT(err, above_neck ? 0.01f : 0.001f) << s.joint_name(j);
  }
  // Nothing before the hips arrive.
  rig::Pose none = s.rest_pose();
  EXPECT_FALSE(pose_from_vmc(VmcState{}, s, enc.bones(), none));
}

// Over a real socket: VmcSender to a VmcReceiver on a port the kernel picked.
TEST(VmcReceive, SenderToReceiverOverLoopback) {
  auto rx = VmcReceiver::open("127.0.0.1:0");
  ASSERT_TRUE(rx) << rx.error().what();
  auto tx = VmcSender::open((*rx)->endpoint());
  ASSERT_TRUE(tx) << tx.error().what();
  const auto s = default_skeleton();
  ASSERT_TRUE((*tx)->add_avatar(s));
  for (int f = 0; f < 10; ++f) ASSERT_GT((*tx)->send(0, some_pose(s), 0.01 * f), 0u);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while ((*rx)->state().frames < 10 && std::chrono::steady_clock::now() < end) {
    (*rx)->poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_EQ((*rx)->state().frames, 10u);
  EXPECT_EQ((*rx)->stats().refused_total(), 0u);
  EXPECT_TRUE((*rx)->state().bones[size_t(unity_bone_index("LeftLowerArm"))].present);
}

// liblo's oscsend, a third-party OSC implementation, as the sender: a VMC bone, a VMC tracker
// and VRChat OSC trackers, each in Unity's frame.
TEST(VmcReceive, LibloSenderIsUnderstood) {
  if (std::system("command -v oscsend > /dev/null") != 0) GTEST_SKIP() << "oscsend (liblo-tools) not installed";
  auto rx = VmcReceiver::open("127.0.0.1:0");
  ASSERT_TRUE(rx);
  const std::string to = "oscsend 127.0.0.1 " + std::to_string((*rx)->port()) + " ";
  // Left upper arm turned 90° about Unity's +Z (down towards the body's side).
  ASSERT_EQ(std::system((to + "/VMC/Ext/Bone/Pos sfffffff LeftUpperArm 0.1 0 0 0 0 0.70710678 0.70710678").c_str()), 0);
  ASSERT_EQ(std::system((to + "/VMC/Ext/Tra/Pos sfffffff LHR-1234 0.5 1.0 0.25 0 0 0 1").c_str()), 0);
  ASSERT_EQ(std::system((to + "/tracking/trackers/3/position fff 0.1 0.2 0.3").c_str()), 0);
  ASSERT_EQ(std::system((to + "/tracking/trackers/head/rotation fff 0 90 0").c_str()), 0);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while ((*rx)->stats().datagrams < 4 && std::chrono::steady_clock::now() < end) {
    (*rx)->poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const VmcState& st = (*rx)->state();
  ASSERT_EQ((*rx)->stats().refused_total(), 0u);
  const TrackedPose& arm = st.bones[size_t(unity_bone_index("LeftUpperArm"))];
  ASSERT_TRUE(arm.present);
  EXPECT_TRUE(near(arm.orientation, glm::quat(0.70710678f, 0, 0, -0.70710678f)));  // about Mimic's −Z
  EXPECT_NEAR(arm.position_m.x, -0.1f, 1e-6f);
  ASSERT_EQ(st.device_count, 1u);
  EXPECT_STREQ(st.devices[0].serial.data(), "LHR-1234");
  EXPECT_EQ(st.devices[0].kind, 'T');
  EXPECT_NEAR(st.devices[0].pose.position_m.x, -0.5f, 1e-6f);
  EXPECT_NEAR(st.osc_trackers[3].position_m.x, -0.1f, 1e-6f);
  EXPECT_NEAR(st.osc_trackers[3].position_m.z, 0.3f, 1e-6f);
  // Unity's Euler (0, 90, 0) turns +Z to +X (the right); in Mimic's frame that is −X.
  EXPECT_NEAR(glm::length(st.osc_trackers[0].orientation * glm::vec3(0, 0, 1) - glm::vec3(-1, 0, 0)), 0.0f, 1e-5f);
  // A tracker is placed by its position: the head's rotation alone does not stand it at the origin.
  EXPECT_TRUE(st.osc_trackers[3].present);
  EXPECT_FALSE(st.osc_trackers[0].present);
}

Bytes osc_string(const std::string& s) {
  Bytes b(s.begin(), s.end());
  b.push_back(0);
  while (b.size() % 4) b.push_back(0);
  return b;
}

Bytes message(const std::string& address, const std::string& tags, std::vector<float> floats = {}) {
  Bytes b = osc_string(address);
  const Bytes t = osc_string("," + tags);
  b.insert(b.end(), t.begin(), t.end());
  for (float f : floats) {
    uint32_t v;
    std::memcpy(&v, &f, 4);
    for (int k = 3; k >= 0; --k) b.push_back(uint8_t(v >> (8 * k)));
  }
  return b;
}

Bytes bundle(const std::vector<Bytes>& parts) {
  Bytes b = osc_string("#bundle");
  for (int i = 0; i < 7; ++i) b.push_back(0);
  b.push_back(1);
  for (const auto& p : parts) {
    const uint32_t n = uint32_t(p.size());
    for (int k = 3; k >= 0; --k) b.push_back(uint8_t(n >> (8 * k)));
    b.insert(b.end(), p.begin(), p.end());
  }
  return b;
}

// Every kind of bad input is counted by its reason and changes nothing.
TEST(VmcReceive, MalformedInputIsCountedByReasonAndIgnored) {
  VmcState state;
  VmcReceiveStats stats;
  auto apply = [&](const Bytes& b) { apply_vmc_packet(b, 1.0, state, stats); };
  Bytes truncated = message("/tracking/trackers/1/position", "fff", {1, 2, 3});
  truncated.resize(truncated.size() - 4);
  apply(truncated);
  EXPECT_EQ(stats.refused[size_t(osc::Error::truncated)], 1u);
  apply(Bytes{'/', 'a', 0});
  EXPECT_EQ(stats.refused[size_t(osc::Error::misaligned)], 1u);
  apply(osc_string("no-slash"));
  EXPECT_EQ(stats.refused[size_t(osc::Error::bad_address)], 1u);
  Bytes no_comma = osc_string("/VMC/Ext/OK");
  const Bytes bad_tags = osc_string("i");
  no_comma.insert(no_comma.end(), bad_tags.begin(), bad_tags.end());
  apply(no_comma);
  EXPECT_EQ(stats.refused[size_t(osc::Error::bad_type_tags)], 1u);
  apply(message("/VMC/Ext/OK", "X"));
  EXPECT_EQ(stats.refused[size_t(osc::Error::unknown_type)], 1u);
  apply(bundle({bundle({bundle({bundle({bundle({message("/VMC/Ext/OK", "")})})})})}));
  EXPECT_EQ(stats.refused[size_t(osc::Error::too_deep)], 1u);
  Bytes trailing = message("/tracking/trackers/1/position", "fff", {1, 2, 3});
  trailing.insert(trailing.end(), 4, 0);
  apply(trailing);
  EXPECT_EQ(stats.refused[size_t(osc::Error::trailing_bytes)], 1u);
  apply(message("/tracking/trackers/1/position", "ff", {1, 2}));
  EXPECT_EQ(stats.refused[size_t(osc::Error::wrong_arguments)], 1u);
  const float nan = std::nanf("");
  apply(message("/tracking/trackers/2/position", "fff", {nan, 0, 0}));
  EXPECT_EQ(stats.non_finite, 1u);
  Bytes finger = osc_string("/VMC/Ext/Bone/Pos");
  const Bytes ft = osc_string(",sfffffff");
  finger.insert(finger.end(), ft.begin(), ft.end());
  const Bytes name = osc_string("LeftIndexProximal");
  finger.insert(finger.end(), name.begin(), name.end());
  for (float f : {0.f, 0.f, 0.f, 0.f, 0.f, 0.f, 1.f}) {
    uint32_t v;
    std::memcpy(&v, &f, 4);
    for (int k = 3; k >= 0; --k) finger.push_back(uint8_t(v >> (8 * k)));
  }
  apply(finger);
  EXPECT_EQ(stats.unknown_bones, 1u);
  apply(message("/avatar/parameters/Smile", "f", {1}));
  EXPECT_EQ(stats.other_addresses, 1u);
  // Nothing was set.
  for (const auto& b : state.bones) EXPECT_FALSE(b.present);
  for (const auto& t : state.osc_trackers) EXPECT_FALSE(t.present);
  EXPECT_EQ(state.frames, 0u);
}

}  // namespace
}  // namespace mimic::net::vmc_receive_test
