// A SensorSource over a SensorRig: the virtual body's sensors delivered as a live tracker would
// deliver them. Tick k's samples are released once the clock passes start + t_k + latency, and
// carry host_time_s on that clock. The clock is the host's steady clock in real runs and a
// ManualClock in tests.
//
// A consumer that polls late gets every tick it missed, in order (at most out.size() samples
// per poll; the rest wait for the next poll), just as a serial driver drains its buffer.
// poll() never blocks, allocates or throws.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mimic/devices/source.h"
#include "mimic/core/clock.h"
#include "mimic/sim/sensor_rig.h"

namespace mimic::sim {

class SimSource final : public devices::SensorSource {
 public:
  // `description` shows in status(), e.g. "sim:walk 6 sensors 100 Hz seed 1".
  SimSource(SensorRig rig, std::shared_ptr<const Clock> clock, std::string description);

  Status start() override;  // starts (or restarts, from tick 0) the time line at clock.now_s()
  size_t poll(std::span<devices::SensorSample> out) override;
  devices::DeviceStatus status() const override { return status_; }
  void stop() override;

  const SensorRig& rig() const { return rig_; }
  double start_time_s() const { return start_s_; }

 private:
  SensorRig rig_;
  std::shared_ptr<const Clock> clock_;
  devices::DeviceStatus status_;
  std::vector<devices::SensorSample> tick_;  // one tick's samples, sensor_count() entries
  size_t pending_ = 0;                       // samples of tick_ not handed out yet, from the end
  double start_s_ = 0;
  bool running_ = false;
};

}  // namespace mimic::sim
