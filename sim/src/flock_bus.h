// Internal to the virtual Flock: the units on its Fast Bird Bus and the flock-wide state that
// EXAMINE VALUE reads and CHANGE VALUE writes (flock_bus.cpp). Owned by the simulator thread.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "mimic/devices/flock_packet.h"
#include "mimic/sim/virtual_flock.h"

namespace mimic::sim::detail {

// One unit on the Fast Bird Bus.
struct Unit {
  int address = 0;
  bool sensor = true;
  bool transmitter = false;
  bool erc = false;
  devices::flock::Format format = devices::flock::Format::position_angles;  // the power-up format
  bool button_mode = false;
  devices::flock::Hemisphere hemisphere = devices::flock::Hemisphere::forward;
  int16_t position_scaling = 0;  // parameter 3: 0 = 36 in, 1 = 72 in
  int error_code = 0;
  int error_extra = 0;
  std::map<uint8_t, std::vector<uint8_t>> params;  // CHANGE values kept for EXAMINE
};

struct FlockBus {
  VirtualFlockConfig cfg;
  std::vector<Unit> units;  // index = address (standalone: a single unit at 0)
  bool standalone = false;
  int master = 1;
  bool configured = false;
  uint32_t running_mask = 0;
  bool group_mode = false;
  bool streaming = false;
  int stream_address = 0;
  bool sleeping = false;
  int rate_count = 0;
  double busy_until_s = -1;

  double rate_hz() const { return devices::flock::measurement_rate_hz(rate_count, cfg.crystal_mhz); }
  bool unit_exists(int a) const {
    if (standalone) return a == 0;
    return a >= 1 && a < static_cast<int>(units.size());
  }
  // The error a unit reports next (an address no unit has: the master's).
  void set_error(int address, int code, int extra = 0) {
    Unit& u = units[unit_exists(address) ? static_cast<size_t>(address) : static_cast<size_t>(master)];
    u.error_code = code;
    u.error_extra = extra;
  }
  // EXAMINE VALUE parameter `p` of unit `u`: the reply's bytes, or none (and an error set) for a
  // parameter the unit does not have. Reading the error code clears it.
  std::vector<uint8_t> examine_reply(Unit& u, uint8_t p);
  // CHANGE VALUE parameter `p` of unit `u` to `data` (sized for p) at sim time `now`.
  void change(Unit& u, uint8_t p, std::span<const uint8_t> data, double now);
};

}  // namespace mimic::sim::detail
