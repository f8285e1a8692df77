// The threads that share a tick's writes to subscribers. The calling thread runs lane 0 itself and
// waits for the others: one wake-up and one wait per tick, nothing locked per write. Workers are
// started by prepare() (or on first use) and take the caller's scheduling policy (SCHED_FIFO
// under --realtime).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace mimic::net {

class FanoutPool {
 public:
  using Job = void (*)(void* context, int lane);
  FanoutPool() = default;
  ~FanoutPool();
  FanoutPool(const FanoutPool&) = delete;
  FanoutPool& operator=(const FanoutPool&) = delete;

  // Runs job(context, lane) for every lane in [0, lanes), lane 0 on the calling thread, and
  // returns when all are done. Returns the number of lanes that ran: fewer than asked (down to 1,
  // the caller alone) when worker threads could not be started. Never throws.
  int run(int lanes, Job job, void* context) noexcept;
  // Starts the workers for `lanes` lanes now, not on first use (starting a thread allocates:
  // not for a realtime tick). Returns the lanes available.
  int prepare(int lanes) noexcept {
    return lanes > 1 && int(workers_.size()) < lanes - 1 ? 1 + start_workers(lanes - 1) : lanes;
  }

 private:
  void work(int lane);
  int start_workers(int wanted) noexcept;
  void follow_caller_policy() noexcept;

  std::mutex mutex_;
  std::condition_variable start_, done_;
  uint64_t generation_ = 0;
  int lanes_ = 0, pending_ = 0;
  Job job_ = nullptr;
  void* context_ = nullptr;
  bool quit_ = false;
  std::vector<std::thread> workers_;  // worker i runs lane i + 1
  int policy_ = -1, priority_ = -1;   // what the workers were given
};

}  // namespace mimic::net
