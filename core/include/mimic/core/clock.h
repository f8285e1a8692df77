// Time for the realtime loop, simulated and replayed sources: the host's monotonic clock in real
// runs, a clock the caller steps by hand in tests, so timing logic is checked without sleeping.
#pragma once

#include <chrono>

namespace mimic {

// Seconds on std::chrono::steady_clock's time line: what SteadyClock reads, for code that
// timestamps without being handed a clock (device drivers, receive threads).
inline double steady_now_s() noexcept {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

class Clock {
 public:
  virtual ~Clock() = default;
  virtual double now_s() const = 0;  // seconds on a monotonic time line; never goes back
};

// std::chrono::steady_clock in seconds.
class SteadyClock final : public Clock {
 public:
  double now_s() const override { return steady_now_s(); }
};

// Moves only when told to.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(double start_s = 0) : now_s_(start_s) {}
  double now_s() const override { return now_s_; }
  void set(double t_s) { now_s_ = t_s; }
  void advance(double dt_s) { now_s_ += dt_s; }

 private:
  double now_s_;
};

}  // namespace mimic
