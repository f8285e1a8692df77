// A SensorSource over a recorded log: the samples come back with their recorded spacing, at a
// chosen speed, optionally looped, optionally from an offset into the recording.
//
// Time line. The replay starts at the log time `from_s` after the first sample (log times are
// the recorded host_time_s). When start() is called at clock time t0, a sample recorded at log
// time h is released once clock.now_s() ≥ t0 + (h − (first + from_s)) / speed, in file order.
// speed = 0 releases everything as fast as it is polled. Looping replays [first + from_s, last]
// again and again; each pass is shifted by the cycle length (last − first − from_s + one sample
// period, the period being 1 / header rate, else the mean spacing), so times keep increasing.
//
// Emitted samples: host_time_s is put on the replay clock (t0 + elapsed replay time), or kept
// as recorded plus the loop shift when keep_log_times is set (for dumps). device_time_s is kept
// plus the loop shift. A damaged log replays up to the damage; status().last_error says where
// it stopped. After the last sample of a non-looping replay, status().state is disconnected
// and finished() is true.
//
// poll() never blocks, allocates or throws.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "mimic/devices/source.h"
#include "mimic/core/clock.h"
#include "mimic/sim/log.h"

namespace mimic::sim {

struct ReplayOptions {
  double speed = 1.0;  // 2 = twice as fast; 0 = unpaced
  bool loop = false;
  double from_s = 0.0;          // seconds after the first sample
  bool keep_log_times = false;  // host_time_s as recorded (plus the loop shift)
};

class ReplaySource final : public devices::SensorSource {
 public:
  // Fails on a negative or non-finite speed or offset, or an offset past the last sample.
  static Result<std::unique_ptr<ReplaySource>> create(LogContents log, const ReplayOptions& options,
                                                      std::shared_ptr<const Clock> clock);
  // read_log(path) then create(); a damaged log still opens (see status().last_error).
  static Result<std::unique_ptr<ReplaySource>> open(const std::string& path, const ReplayOptions& options,
                                                    std::shared_ptr<const Clock> clock);

  Status start() override;  // (re)starts at the beginning of the replayed segment
  size_t poll(std::span<devices::SensorSample> out) override;
  devices::DeviceStatus status() const override { return status_; }
  void stop() override;

  const LogContents& log() const { return log_; }
  bool finished() const { return finished_; }
  uint64_t loops_completed() const { return loop_; }
  double cycle_s() const { return cycle_s_; }
  // Log time (recorded host time, before loop shifts) of the segment's start.
  double segment_start_s() const { return segment_start_s_; }

 private:
  ReplaySource(LogContents log, const ReplayOptions& options, std::shared_ptr<const Clock> clock);

  LogContents log_;
  ReplayOptions options_;
  std::shared_ptr<const Clock> clock_;
  devices::DeviceStatus status_;
  size_t begin_ = 0;   // first sample of the segment
  size_t cursor_ = 0;  // next sample to release
  uint64_t loop_ = 0;  // passes completed
  double segment_start_s_ = 0;
  double cycle_s_ = 0;
  double start_clock_s_ = 0;
  double last_time_s_ = 0;  // for samples with non-finite recorded times
  bool running_ = false;
  bool finished_ = false;
};

}  // namespace mimic::sim
