// Sources of tracker data, whatever is behind them (a serial Flock of Birds, a Spaceball, a
// USB SpaceMouse, a simulator, a recorded log). The realtime loop polls; polling never blocks,
// never allocates and never throws: a failure becomes status (stale, disconnected) and the
// source keeps trying to recover on its own.
#pragma once

#include <cstddef>
#include <map>
#include <span>
#include <string>
#include <string_view>

#include "mimic/core/result.h"
#include "mimic/devices/sample.h"

namespace mimic::devices {

// "flock:/dev/ttyUSB0?birds=4&baud=115200", "spaceball:/dev/ttyS0", "magellan:/dev/ttyS1",
// "spacemouse" (first USB device found), "sim:walk", "replay:session.mlog", "bvh:clip.bvh".
struct SourceSpec {
  std::string scheme;                         // flock, spaceball, magellan, spacemouse, sim, replay, bvh, vmc
  std::string target;                         // device path, motion name, file path; may be empty
  std::map<std::string, std::string> params;  // after '?', '&'-separated key=value
  std::string text;                           // as given
};

// Clear error on an unknown scheme, a missing target where one is required, or a bad parameter.
Result<SourceSpec> parse_source_spec(std::string_view text);

class SensorSource {
 public:
  virtual ~SensorSource() = default;
  virtual Status start() = 0;
  // Copies samples that arrived since the last poll into `out` (at most out.size()) and
  // returns how many. Never blocks, allocates or throws.
  virtual size_t poll(std::span<SensorSample> out) = 0;
  virtual DeviceStatus status() const = 0;
  virtual void stop() = 0;
};

class InputSource {
 public:
  virtual ~InputSource() = default;
  virtual Status start() = 0;
  // Latest 6-DOF input frame; false when nothing new arrived since the last poll.
  virtual bool poll(InputFrame& out) = 0;
  virtual DeviceStatus status() const = 0;
  virtual void stop() = 0;
};

}  // namespace mimic::devices
