// A virtual serial Spaceball (2003, 3003 or 4000 FLX) speaking the real byte protocol
// (docs/device-protocols.md §2, §5.6): power-up banner (once, or on every open of the port), replies
// to `@` reset, `hm`, `"`, `k` and `%` echo, echoes of configuration commands, `?cmd` for
// unknown ones, D packets only once enabled (MSS… / M…) with the true interval in 1/16 ms, and
// K / '.' packets on button changes. Commands that arrive while it boots (before the banner)
// are ignored. Output is paced at the line's baud rate (10 bits a byte).
#pragma once

#include <memory>
#include <random>
#include <string>

#include "mimic/core/result.h"
#include "mimic/devices/spaceball_packet.h"
#include "mimic/sim/input_pattern.h"
#include "mimic/sim/serial_device.h"

namespace mimic::sim {

struct VirtualSpaceballConfig {
  devices::spaceball::Model model = devices::spaceball::Model::sb4000flx;
  std::string firmware;      // "2.42" style; empty: the model's usual version
  bool right_handed = true;  // 4000 FLX handedness bit and descriptor
  // false: a device that was already plugged in and running when the simulator started (its
  // power-up banner went to a closed port long ago): a host that opens the port is answered at
  // once, and finds it in whatever state the last host left it. true: a cold start on every
  // open: the host opening the port powers it up and it ignores commands until its banner,
  // power_up_delay_s later, as when the computer and the device are switched on together.
  bool power_up_on_open = false;
  double power_up_delay_s = 2.0;  // power-up → XON + banner
  double reset_delay_s = 1.0;     // `@` reset → banner
  double reply_delay_s = 0.003;   // command → reply
  double data_period_s = 0.03;    // D packets while enabled and the ball is deflected [?]
  unsigned baud = 9600;           // pacing of output; 0 sends at once
  uint64_t seed = 1;
  InputPattern input;  // empty: default_input_pattern(seed)
  devices::spaceball::Scaling scaling;
  // Line faults, per D packet, drawn from the seed: line noise (high-bit bytes and a CR) before
  // the packet, a byte of the packet lost, or a corrupt `^` escape inside it.
  double fault_rate = 0.0;
};

// Protocol engine on the caller's clock (no I/O).
class SpaceballDevice final : public SerialDevice {
 public:
  explicit SpaceballDevice(VirtualSpaceballConfig config);

  void host_opened(double now_s) override;
  void receive(std::span<const uint8_t> bytes, double now_s) override;
  void advance(double now_s) override;

  bool data_enabled() const { return enabled_; }
  uint64_t resets() const { return resets_; }
  uint64_t d_packets() const { return d_packets_; }
  uint64_t faults() const { return faults_; }

 private:
  void power_up(double now_s);
  void command(std::string_view cmd, double now_s);
  void banner(const char* reset_word, double at_s);
  void reply(std::span<const uint8_t> body, double at_s);
  void reply(std::string_view text, double at_s);
  void send_keys(uint32_t buttons, double at_s);
  void send_displacement(const devices::spaceball::Axes& axes, uint16_t period, double at_s);

  VirtualSpaceballConfig cfg_;
  std::string firmware_;
  std::string line_;  // host command being assembled
  bool enabled_ = false;
  bool banner_pending_ = false;
  double banner_at_s_ = 0;
  const char* banner_word_ = "poweron ";
  double power_on_s_ = 0;  // pattern time origin
  double next_data_s_ = 0;
  double last_data_s_ = -1;
  bool at_rest_sent_ = false;
  uint32_t buttons_ = 0;
  uint64_t resets_ = 0;
  uint64_t d_packets_ = 0;
  uint64_t faults_ = 0;
  std::mt19937_64 fault_rng_;
};

// Firmware string a model reports when none is configured: 2003 → "2.15", 3003 → "2.63",
// 4000 FLX → "2.43".
std::string default_spaceball_firmware(devices::spaceball::Model model);

// "4000flx", "3003", "2003" → model; Errc::invalid_argument otherwise.
Result<devices::spaceball::Model> parse_spaceball_model(std::string_view name);

// The engine served on a new pseudo-terminal; path() is what a driver opens.
Result<std::unique_ptr<PtyServer>> start_virtual_spaceball(VirtualSpaceballConfig config,
                                                           const std::string& log_path = {});

}  // namespace mimic::sim
