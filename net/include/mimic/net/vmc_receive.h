// A UDP socket receiving what consumer full-body trackers send over OSC/UDP (VMC performer data,
// VRChat-style OSC trackers), decoded in place into the latest state of each bone and tracker
// (mimic/net/vmc_decode.h).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "mimic/core/result.h"
#include "mimic/net/vmc_decode.h"

namespace mimic::net {

// A UDP socket receiving VMC and OSC tracker datagrams, on loopback unless told otherwise.
class VmcReceiver {
 public:
  // "[HOST:]PORT" (HOST defaults to 127.0.0.1; PORT 0 picks a free one).
  static Result<std::unique_ptr<VmcReceiver>> open(const std::string& host_port);
  ~VmcReceiver();
  VmcReceiver(const VmcReceiver&) = delete;
  VmcReceiver& operator=(const VmcReceiver&) = delete;

  // Reads what has arrived, at most `max_datagrams`, without blocking; never allocates or throws.
  // Returns the datagrams read.
  size_t poll(size_t max_datagrams = 64);
  const VmcState& state() const { return state_; }
  const VmcReceiveStats& stats() const { return stats_; }
  uint16_t port() const;
  std::string endpoint() const;

 private:
  VmcReceiver() = default;
  int fd_ = -1;
  VmcState state_;
  VmcReceiveStats stats_;
  std::array<uint8_t, 65536> buffer_{};
};

}  // namespace mimic::net
