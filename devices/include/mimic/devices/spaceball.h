// Serial Spaceball driver (2003, 3003, 4000 FLX) as an InputSource.
//
// Start-up (on every open of the port): `\r@RESET\r`, then on the "@1" banner the configuration
// `\rCB\rNT\rFTp\rFRp\rP@r@r\rMSSV\rZ\rk\rhm\r` (libsball/VRPN's set plus a key query and the
// model query); a 4000 FLX (`Hv…` reply) also gets `"` for its handedness. An '@' banner at any
// later time means the device reset itself, and the configuration is sent again.
// A silent device is asked for its key state (`k`); when that goes unanswered for dead_after_s
// the port is closed and reopened, and status().reconnects counts it.
#pragma once

#include <memory>
#include <string>

#include "mimic/core/result.h"
#include "mimic/devices/source.h"
#include "mimic/devices/spaceball_packet.h"

namespace mimic::devices {

struct SpaceballOptions {
  std::string path;  // serial device, e.g. /dev/ttyS0 or a pty
  spaceball::Scaling scaling;
  unsigned baud = 9600;
  double reset_timeout_s = 2.5;       // wait for "@1" before the reset is sent again
  double probe_after_s = 1.0;         // silence before a key-state probe
  double dead_after_s = 3.5;          // silence before the port is reopened
  double reconnect_interval_s = 0.5;  // between attempts to open the port
};

// Never fails: a missing device shows as status().state == disconnected until it appears.
std::unique_ptr<InputSource> make_spaceball_source(SpaceballOptions options);

// From a "spaceball:/dev/ttyS0?baud=9600&probe=1&dead=3.5" spec (scheme and target already
// split). Clear error on an unknown or malformed parameter.
Result<SpaceballOptions> spaceball_options(const SourceSpec& spec);

}  // namespace mimic::devices
