// A virtual serial Magellan / SpaceMouse speaking the real protocol (docs/device-protocols.md
// §3, §5.7): `vQ` → version line, exact command echoes (`z\rm3\rc30\rnH\rb\r` for VRPN's
// start-up), `e1` + command for unknown commands, silence towards the Spaceball probe (`@…`),
// `d` packets while the values change once a mode is set, `k` on button changes. Every data
// character is a valid even-parity nibble; output is paced at 9600 baud, 8N2 (11 bits a byte).
#pragma once

#include <memory>
#include <string>

#include "mimic/core/result.h"
#include "mimic/devices/magellan_packet.h"
#include "mimic/sim/input_pattern.h"
#include "mimic/sim/serial_device.h"

namespace mimic::sim {

struct VirtualMagellanConfig {
  std::string version = "  MAGELLAN  Version 6.60  3Dconnexion GmbH 05/11/01";
  double reply_delay_s = 0.003;
  double data_period_s = 0.02;  // d packets at most this often while the values change [?]
  unsigned baud = 9600;         // 0 sends at once
  uint64_t seed = 1;
  InputPattern input;  // empty: default_input_pattern(seed)
  devices::magellan::Scaling scaling;
};

class MagellanDevice final : public SerialDevice {
 public:
  explicit MagellanDevice(VirtualMagellanConfig config);

  void host_opened(double now_s) override;
  void receive(std::span<const uint8_t> bytes, double now_s) override;
  void advance(double now_s) override;

  unsigned mode() const { return mode_; }

 private:
  void command(const std::string& cmd, double now_s);

  VirtualMagellanConfig cfg_;
  std::string line_;
  unsigned mode_ = 0;  // m nibble: bit0 rotation, bit1 translation
  double power_on_s_ = 0;
  double next_data_s_ = 0;
  devices::magellan::Axes last_sent_{};
  bool sent_any_ = false;
  uint32_t buttons_ = 0;
};

Result<std::unique_ptr<PtyServer>> start_virtual_magellan(VirtualMagellanConfig config,
                                                          const std::string& log_path = {});

}  // namespace mimic::sim
