// A simulated 3Dconnexion USB device at the report level (docs/device-protocols.md §4.3, §5.8):
// reports 1 and 2 alternating every 8 ms for the 7-byte models, one 13-byte report 1 every
// 16 ms for the newer ones, report 3 on button changes, zero reports repeated 3 times after the
// cap comes to rest and then silence, and a 17h battery report now and then on wireless models.
// A pty cannot carry HID, so the reports go straight into devices::HidReportSource, the decoder
// the hidapi driver uses.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>

#include "mimic/devices/hid_packet.h"
#include "mimic/devices/source.h"
#include "mimic/sim/input_pattern.h"

namespace mimic::sim {

struct VirtualHidConfig {
  uint16_t vendor_id = devices::hid::kVendorLogitech;
  uint16_t product_id = 0xC626;  // SpaceNavigator
  uint64_t seed = 1;
  InputPattern input;  // empty: default_input_pattern(seed)
  devices::hid::Scaling scaling;
  double battery_period_s = 10.0;
};

// Report generator on the caller's clock.
class VirtualHid {
 public:
  using Emit = std::function<void(std::span<const uint8_t> report)>;
  explicit VirtualHid(VirtualHidConfig config);

  // Emits every report due up to now_s (t = 0 is plug-in).
  void advance(double now_s, const Emit& emit);
  const devices::hid::Model& model() const { return *model_; }

 private:
  VirtualHidConfig cfg_;
  const devices::hid::Model* model_;
  double next_s_ = 0;
  double next_battery_s_ = 0;
  bool rotation_next_ = false;  // 7-byte models alternate reports 1 and 2
  int zero_repeats_left_ = 6;   // zero reports still to send once at rest
  uint32_t buttons_ = 0;
  int battery_ = 100;
};

// A simulated SpaceMouse as an InputSource: a thread runs VirtualHid on the wall clock and feeds
// its reports to a HidReportSource. Fails (Errc::invalid_argument) for ids not in hid::models().
Result<std::unique_ptr<devices::InputSource>> make_simulated_spacemouse(VirtualHidConfig config);

}  // namespace mimic::sim
