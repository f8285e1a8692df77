// VMC protocol output (Virtual Motion Capture: OSC over UDP), so VTuber and VR tools that take
// VMC can be driven by Mimic. Each frame is one OSC bundle:
//   /VMC/Ext/Root/Pos "root" px py pz qx qy qz qw      (identity: the Hips bone carries the body)
//   /VMC/Ext/Bone/Pos <Unity humanoid bone> px py pz qx qy qz qw   (local to the parent bone)
//   /VMC/Ext/OK 1
//   /VMC/Ext/T <time_s>
// VMC uses Unity's left-handed frame (+Y up, +Z forward, +X to the character's right), so
// Mimic's positions are mirrored in x and rotations (x, y, z, w) become (x, −y, −z, w). Mimic's
// zero posture is the T-pose Unity humanoids rest in, so local rotations carry over directly.
// neck_upper folds into Neck (Unity has two neck/head bones where Mimic has three).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/avatar/skeleton.h"
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
std::vector<VmcBone> vmc_bone_map(const avatar::Skeleton& skeleton);

class VmcEncoder {
 public:
  explicit VmcEncoder(const avatar::Skeleton& skeleton);
  // One bundle for the pose into `out` (cleared first; no allocation once it has grown to a
  // frame's size).
  void encode(const avatar::Pose& pose, double time_s, std::vector<uint8_t>& out) const;
  const std::vector<VmcBone>& bones() const { return bones_; }

 private:
  avatar::Skeleton skeleton_;
  std::vector<VmcBone> bones_;
};

// Sends VMC bundles to a UDP receiver ("127.0.0.1:39539" is VMC's usual port).
class VmcSender {
 public:
  static Result<std::unique_ptr<VmcSender>> open(const std::string& host_port, const avatar::Skeleton& skeleton);
  ~VmcSender();
  // Never throws; allocation-free after the first frame. Returns bytes sent (0 on failure).
  size_t send(const avatar::Pose& pose, double time_s);

 private:
  struct Impl;
  explicit VmcSender(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::net
