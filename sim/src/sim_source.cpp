#include "mimic/sim/sim_source.h"

namespace mimic::sim {

SimSource::SimSource(SensorRig rig, std::shared_ptr<const Clock> clock, std::string description)
    : rig_(std::move(rig)), clock_(std::move(clock)) {
  status_.description = std::move(description);
  tick_.resize(static_cast<size_t>(rig_.sensor_count()));
}

Status SimSource::start() {
  rig_.reset();
  pending_ = 0;
  start_s_ = clock_->now_s();
  running_ = true;
  status_.state = devices::DeviceState::streaming;
  status_.records = 0;
  status_.last_error.clear();
  return {};
}

void SimSource::stop() {
  running_ = false;
  pending_ = 0;
  status_.state = devices::DeviceState::disconnected;
}

size_t SimSource::poll(std::span<devices::SensorSample> out) {
  if (!running_) return 0;
  const double now = clock_->now_s();
  size_t n = 0;
  while (n < out.size()) {
    if (pending_ == 0) {
      // A nanosecond of slack: rounding in the time arithmetic must not hold a tick back.
      if (start_s_ + rig_.next_host_time_s() > now + 1e-9) break;
      rig_.step(tick_, start_s_);
      pending_ = tick_.size();
      ++status_.records;
    }
    out[n++] = tick_[tick_.size() - pending_];
    --pending_;
  }
  return n;
}

}  // namespace mimic::sim
