// VMC protocol output (Virtual Motion Capture: OSC over UDP), so VTuber and VR tools that take
// VMC can be driven by Mimic. Each frame is these OSC messages, in this order:
//   /VMC/Ext/Root/Pos "root" px py pz qx qy qz qw      (identity: the Hips bone carries the body)
//   /VMC/Ext/Bone/Pos <Unity humanoid bone> px py pz qx qy qz qw   (local to the parent bone)
//   /VMC/Ext/OK 1
//   /VMC/Ext/T <seconds since the stream started>
// packed into as few OSC bundles as keep each datagram within max_bundle_bytes (1,400 by
// default: one datagram on a 1,500-byte Ethernet path over IPv4 or IPv6, with room for a
// tunnel's headers, so no IP fragment is ever lost alone). Mimic's default skeleton takes two
// bundles; OK and T always close the last one, so a receiver that applies a frame on OK sees
// all its bones first. VMC has no avatar index: VmcSender sends avatar i to port + i, one
// receiver (one model) per port, as VMC tools expect.
// VMC uses Unity's left-handed frame (+Y up, +Z forward, +X to the character's right), so
// Mimic's positions are mirrored in x and rotations (x, y, z, w) become (x, −y, −z, w). Mimic's
// zero posture is the T-pose Unity humanoids rest in, so local rotations carry over directly.
// neck_upper folds into Neck (Unity has two neck/head bones where Mimic has three).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::net {

// Appends OSC 1.0 messages (big-endian, 4-byte aligned) to a buffer reserved up front.
class OscWriter {
 public:
  explicit OscWriter(std::vector<uint8_t>& out) : out_(out) {}
  void begin_bundle(uint64_t timetag = 1);  // 1 = "immediately"
  // Starts a message inside the current bundle (or a bare message outside one).
  void begin_message(std::string_view address, std::string_view type_tags);  // tags without ','
  void arg_string(std::string_view s);
  void arg_float(float f);
  void arg_int(int32_t i);
  void end_message();

 private:
  void pad();
  void put32(uint32_t v);
  std::vector<uint8_t>& out_;
  size_t message_start_ = 0;
  bool in_bundle_ = false;
};

struct VmcBone {
  int joint = -1;       // Mimic joint carrying the bone's position and rotation
  int fold_joint = -1;  // a child joint whose rotation folds into this bone (neck_upper), or -1
  std::string unity_name;
};

// Unity humanoid bones for the joints present in `skeleton` (e.g. pelvis -> Hips,
// l_shoulder -> LeftUpperArm, l_knee -> LeftLowerLeg).
std::vector<VmcBone> vmc_bone_map(const rig::Skeleton& skeleton);

inline constexpr size_t kVmcMaxBundleBytes = 1400;
inline constexpr size_t kVmcMaxBundles = 16;

// Where each bundle of a frame ends in the encoder's output: bundle i is [end[i-1], end[i]).
struct VmcBundles {
  std::array<uint32_t, kVmcMaxBundles> end{};
  size_t count = 0;
};

class VmcEncoder {
 public:
  explicit VmcEncoder(const rig::Skeleton& skeleton);
  // The pose's bundles, back to back, into `out` (cleared first; no allocation once it has grown
  // to a frame's size). `stream_time_s` goes out as /VMC/Ext/T. `max_bundle_bytes` must hold
  // the largest single message (about 60 bytes).
  VmcBundles encode(const rig::Pose& pose, double stream_time_s, std::vector<uint8_t>& out,
                    size_t max_bundle_bytes = kVmcMaxBundleBytes) const;
  const std::vector<VmcBone>& bones() const { return bones_; }

 private:
  rig::Skeleton skeleton_;
  std::vector<VmcBone> bones_;
};

// Sends VMC bundles to UDP receivers ("127.0.0.1:39539" is VMC's usual port): avatar i (in the
// order add_avatar was called) to port + i.
class VmcSender {
 public:
  static Result<std::unique_ptr<VmcSender>> open(const std::string& host_port);
  // Fails when port + index would pass 65535 or past 64 avatars.
  Status add_avatar(const rig::Skeleton& skeleton);
  size_t avatar_count() const;
  ~VmcSender();
  // Sends avatar `avatar`'s frame captured at `capture_time_s` (any clock in seconds; /VMC/Ext/T
  // counts from the first frame sent for that avatar). Never throws; allocation-free after the
  // first frame. Returns bytes sent, 0 on failure or for an avatar never added.
  size_t send(size_t avatar, const rig::Pose& pose, double capture_time_s);

 private:
  struct Impl;
  explicit VmcSender(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::net
