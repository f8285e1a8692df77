// libFuzzer target for the OSC reader and the VMC / OSC-tracker decoding on top of it: any bytes
// as one datagram. Invariants: no sanitizer report, one datagram counted, every value kept in the
// state finite and every rotation a unit quaternion.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "mimic/net/vmc_decode.h"

namespace {

void check(const mimic::net::TrackedPose& t) {
  if (!t.present) return;
  const auto& p = t.position_m;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) std::abort();
  const float len = glm::length(t.orientation);
  if (!(std::fabs(len - 1.0f) < 1e-3f)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mimic::net;
  static VmcState state;  // large: not on the stack
  state = VmcState{};
  VmcReceiveStats stats;
  apply_vmc_packet(std::span<const uint8_t>(data, size), 1.0, state, stats);
  if (stats.datagrams != 1 || stats.bytes != size) std::abort();
  check(state.root);
  for (const auto& b : state.bones) check(b);
  for (size_t i = 0; i < state.device_count; ++i) check(state.devices[i].pose);
  if (state.device_count > kMaxVmcDevices) std::abort();
  for (const auto& t : state.osc_trackers) {
    const auto& p = t.position_m;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) std::abort();
  }
  return 0;
}
