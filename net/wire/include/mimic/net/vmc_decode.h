// Decoding what consumer full-body trackers send over OSC/UDP (pure: the socket is VmcReceiver's,
// mimic/net/vmc_receive.h): VMC performer data (SlimeVR's
// server, Sony mocopi, XR Animator, VSeeFace, Mimic's own `run --vmc`) and VRChat-style OSC
// trackers (SlimeVR, phone trackers). Datagrams are decoded in place (osc.h) into the latest
// state of each bone and tracker, converted from Unity's left-handed frame (+X right, +Y up,
// +Z forward) to Mimic's (+X left): positions (x, y, z) → (−x, y, z), rotations
// (x, y, z, w) → (x, −y, −z, w).
//
// VMC (protocol.vmc.info): /VMC/Ext/Root/Pos "root" p q, /VMC/Ext/Bone/Pos <HumanBodyBones> p q
// (local to the parent bone), /VMC/Ext/Tra/Pos, /VMC/Ext/Hmd/Pos, /VMC/Ext/Con/Pos <serial> p q
// (6-DOF devices in the sender's world), /VMC/Ext/OK, /VMC/Ext/T. Extra arguments some senders
// append (VMC's optional scale and offsets) are ignored.
// OSC trackers (VRChat): /tracking/trackers/{1..8,head}/position x y z and /rotation x y z
// (Euler degrees, applied Z, then X, then Y, as Unity's Quaternion.Euler does).
//
// Bad input never stops anything: each refused message or datagram is counted by reason.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/net/osc.h"
#include "mimic/net/vmc_encode.h"  // VmcBone, vmc_bone_map

namespace mimic::net {

// Unity's HumanBodyBones that carry the body (fingers, eyes and jaw are read and ignored).
inline constexpr std::array<std::string_view, 24> kUnityBodyBones = {
    "Hips",          "Spine",         "Chest",        "UpperChest",   "Neck",          "Head",
    "LeftShoulder",  "LeftUpperArm",  "LeftLowerArm", "LeftHand",     "RightShoulder", "RightUpperArm",
    "RightLowerArm", "RightHand",     "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",      "LeftToes",
    "RightUpperLeg", "RightLowerLeg", "RightFoot",    "RightToes",    "LeftEye",       "RightEye"};
int unity_bone_index(std::string_view name);  // -1 when not a body bone
inline constexpr size_t kHipsBone = 0;        // kUnityBodyBones[0]: the bone that places the body
static_assert(kUnityBodyBones[kHipsBone] == "Hips");

struct TrackedPose {
  bool present = false;
  glm::vec3 position_m{0};
  glm::quat orientation{1, 0, 0, 0};
  double received_s = 0;  // host steady-clock time of the datagram that last set it
};

inline constexpr size_t kMaxVmcDevices = 16;  // Tra/Hmd/Con serials remembered
inline constexpr size_t kOscTrackers = 9;     // /tracking/trackers/1..8, and head (index 0)

struct VmcState {
  TrackedPose root;                                       // /VMC/Ext/Root/Pos, Mimic's frame
  std::array<TrackedPose, kUnityBodyBones.size()> bones;  // local to the parent bone, Mimic's frame
  struct Device {
    char kind = 0;                  // 'T' tracker, 'H' HMD, 'C' controller
    std::array<char, 32> serial{};  // NUL-terminated, cut to fit
    TrackedPose pose;
  };
  std::array<Device, kMaxVmcDevices> devices;
  size_t device_count = 0;
  std::array<TrackedPose, kOscTrackers> osc_trackers;  // [0] head, [1..8] trackers
  uint64_t frames = 0;                                 // /VMC/Ext/OK received (a VMC frame is complete)
  double sender_time_s = 0;                            // the last /VMC/Ext/T
};

struct VmcReceiveStats {
  uint64_t datagrams = 0, bytes = 0, messages = 0;
  uint64_t bones = 0, devices = 0, osc_tracker_messages = 0;
  uint64_t unknown_bones = 0;                        // bone names that are not body bones (fingers: expected)
  uint64_t other_addresses = 0;                      // addresses this reader does not use (counted, ignored)
  uint64_t non_finite = 0;                           // NaN or infinite values (the message is dropped)
  uint64_t devices_dropped = 0;                      // Tra/Hmd/Con serials past kMaxVmcDevices
  uint64_t oversized = 0;                            // datagrams longer than the receive buffer (cut by the kernel)
  uint64_t budget_hit = 0;                           // polls that left datagrams for the next one
  std::array<uint64_t, osc::kErrorCount> refused{};  // by osc::Error
  uint64_t refused_total() const {
    uint64_t n = 0;
    for (auto v : refused) n += v;
    return n;
  }
};

// Applies one OSC packet to `state` (the decoding, without a socket: tests and fuzzing).
// `now_s` stamps what it sets.
void apply_vmc_packet(std::span<const uint8_t> packet, double now_s, VmcState& state, VmcReceiveStats& stats);

// The pose a VMC frame describes on `skeleton` (`bones`: vmc_bone_map(skeleton)): each body
// bone's local rotation solved into its joint's DOFs (a folded joint shares its bone's rotation
// half and half: VMC's Neck carries Mimic's neck and neck_upper), the Hips' placement after
// /VMC/Ext/Root/Pos as the root's. Bones not received keep `pose`'s values. False until a Hips
// bone has come. Never allocates (pose.dof_rad has the skeleton's size).
bool pose_from_vmc(const VmcState& state, const rig::Skeleton& skeleton, const std::vector<VmcBone>& bones,
                   rig::Pose& pose);

}  // namespace mimic::net
