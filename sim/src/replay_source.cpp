#include "mimic/sim/replay_source.h"

#include "mimic/core/text.h"

#include <cmath>
#include <cstdio>

namespace mimic::sim {

namespace {

// Recorded host times with non-finite values replaced by the previous finite one (or 0), so a
// damaged timestamp never stalls or reorders the replay.
void sanitize_times(std::vector<devices::SensorSample>& samples) {
  double last = 0;
  for (auto& s : samples) {
    if (std::isfinite(s.host_time_s))
      last = s.host_time_s;
    else
      s.host_time_s = last;
    if (!std::isfinite(s.device_time_s)) s.device_time_s = s.host_time_s;
  }
}

}  // namespace

Result<std::unique_ptr<ReplaySource>> ReplaySource::create(LogContents log, const ReplayOptions& options,
                                                           std::shared_ptr<const Clock> clock) {
  if (!(options.speed >= 0.0) || !std::isfinite(options.speed))
    return fail(Errc::out_of_range, "replay speed must be a finite number ≥ 0 (0 = as fast as possible)");
  if (!(options.from_s >= 0.0) || !std::isfinite(options.from_s))
    return fail(Errc::out_of_range, "replay offset must be a finite number of seconds ≥ 0");
  if (!clock) return fail(Errc::invalid_argument, "replay needs a clock");
  sanitize_times(log.samples);
  if (!log.samples.empty()) {
    const double first = log.samples.front().host_time_s, last = log.samples.back().host_time_s;
    if (options.from_s > 0 && first + options.from_s > last) {
      char msg[160];
      std::snprintf(msg, sizeof msg, "replay offset %.3f s is past the end of the log (%.3f s long)", options.from_s,
                    last - first);
      return fail(Errc::out_of_range, msg);
    }
  }
  return std::unique_ptr<ReplaySource>(new ReplaySource(std::move(log), options, std::move(clock)));
}

Result<std::unique_ptr<ReplaySource>> ReplaySource::open(const std::string& path, const ReplayOptions& options,
                                                         std::shared_ptr<const Clock> clock) {
  auto log = read_log(path);
  if (!log) return tl::unexpected(log.error());
  return create(std::move(*log), options, std::move(clock));
}

ReplaySource::ReplaySource(LogContents log, const ReplayOptions& options, std::shared_ptr<const Clock> clock)
    : log_(std::move(log)), options_(options), clock_(std::move(clock)) {
  const auto& s = log_.samples;
  if (!s.empty()) {
    const double first = s.front().host_time_s, last = s.back().host_time_s;
    segment_start_s_ = first + options_.from_s;
    while (begin_ < s.size() && s[begin_].host_time_s < segment_start_s_) ++begin_;
    double period = 0;
    if (log_.header.rate_hz > 0) {
      period = 1.0 / log_.header.rate_hz;
    } else {
      // Mean spacing between distinct time stamps (several sensors share one time stamp).
      size_t distinct = 0;
      for (size_t i = 1; i < s.size(); ++i) distinct += s[i].host_time_s != s[i - 1].host_time_s ? 1 : 0;
      period = distinct > 0 ? (last - first) / static_cast<double>(distinct) : 0.01;
    }
    cycle_s_ = std::max(last - segment_start_s_, 0.0) + period;
  }
  char text[96];
  std::snprintf(text, sizeof text, ", %zu samples, %.3f s", s.size(),
                s.empty() ? 0.0 : s.back().host_time_s - s.front().host_time_s);
  // The header is the file's text, not ours: escaped before any terminal shows it.
  status_.description =
      "replay of " + (log_.header.source.empty() ? std::string("a log") : terminal_safe(log_.header.source)) + text;
  if (log_.damage) status_.last_error = log_.damage->what();
  cursor_ = begin_;
}

Status ReplaySource::start() {
  cursor_ = begin_;
  loop_ = 0;
  finished_ = begin_ >= log_.samples.size();
  start_clock_s_ = clock_->now_s();
  last_time_s_ = start_clock_s_;
  running_ = true;
  status_.records = 0;
  status_.state = finished_ ? devices::DeviceState::disconnected : devices::DeviceState::streaming;
  return {};
}

void ReplaySource::stop() {
  running_ = false;
  status_.state = devices::DeviceState::disconnected;
}

size_t ReplaySource::poll(std::span<devices::SensorSample> out) {
  if (!running_ || finished_) return 0;
  const double now = clock_->now_s();
  const bool paced = options_.speed > 0;
  // Log time reached by the replay (before loop shifts), with a nanosecond of slack so that
  // rounding in the clock arithmetic never holds a sample back by a whole poll.
  const double reached = segment_start_s_ + (now - start_clock_s_) * options_.speed + 1e-9;
  const auto& s = log_.samples;
  size_t n = 0;
  while (n < out.size()) {
    if (cursor_ >= s.size()) {
      if (!options_.loop) {
        finished_ = true;
        status_.state = devices::DeviceState::disconnected;
        break;
      }
      ++loop_;
      cursor_ = begin_;
    }
    const double shift = static_cast<double>(loop_) * cycle_s_;
    const double log_time = s[cursor_].host_time_s + shift;
    if (paced && log_time > reached) break;
    devices::SensorSample& o = out[n++];
    o = s[cursor_++];
    o.device_time_s += shift;
    if (options_.keep_log_times)
      o.host_time_s = log_time;
    else if (paced)
      o.host_time_s = start_clock_s_ + (log_time - segment_start_s_) / options_.speed;
    else
      o.host_time_s = now;
    ++status_.records;
  }
  if (!finished_ && !options_.loop && cursor_ >= s.size()) {
    finished_ = true;
    status_.state = devices::DeviceState::disconnected;
  }
  return n;
}

}  // namespace mimic::sim
