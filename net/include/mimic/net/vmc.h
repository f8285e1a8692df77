// VMC protocol output (Virtual Motion Capture: OSC over UDP), so VTuber and VR tools that take
// VMC can be driven by Mimic: the encoding (messages, bundles, Unity's frame) is
// mimic/net/vmc_encode.h; this sends it. VMC has no avatar index: VmcSender sends avatar i to
// port + i, one receiver (one model) per port, as VMC tools expect.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/net/vmc_encode.h"

namespace mimic::net {

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
