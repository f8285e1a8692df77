// Serial Magellan / SpaceMouse driver (also the serial Spaceball 5000) as an InputSource.
//
// Line: 9600 baud, 8N2, RTS/CTS. Start-up on every open: after settle_s, `vQ\r` until a `v…`
// reply names the device, then VRPN's `z\rm3\rc30\rnH\rbH\r` (zero, 3D mode, uncompressed,
// null radius 8, beep); the `b` echo completes it. A silent device is asked `vQ` again; when
// that goes unanswered for dead_after_s the port is reopened (status().reconnects).
#pragma once

#include <memory>
#include <string>

#include "mimic/core/result.h"
#include "mimic/devices/magellan_packet.h"
#include "mimic/devices/source.h"

namespace mimic::devices {

struct MagellanOptions {
  std::string path;
  magellan::Scaling scaling;
  unsigned baud = 9600;
  double settle_s = 0.5;       // after opening, before the first command (VRPN waits 1 s)
  double query_retry_s = 1.0;  // `vQ` is repeated until answered
  double probe_after_s = 1.0;
  double dead_after_s = 3.5;
  double reconnect_interval_s = 0.5;
};

std::unique_ptr<InputSource> make_magellan_source(MagellanOptions options);

// From "magellan:/dev/ttyS1?settle=1&probe=1&dead=3.5&scale=7500".
Result<MagellanOptions> magellan_options(const SourceSpec& spec);

}  // namespace mimic::devices
