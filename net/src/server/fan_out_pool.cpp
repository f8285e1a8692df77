#include "server/fan_out_pool.h"

#include <pthread.h>
#include <sched.h>

namespace mimic::net {

FanoutPool::~FanoutPool() {
  {
    std::lock_guard lock(mutex_);
    quit_ = true;
  }
  start_.notify_all();
  for (auto& t : workers_) t.join();
}

int FanoutPool::start_workers(int wanted) noexcept {
  try {
    workers_.reserve(size_t(wanted));
    while (int(workers_.size()) < wanted) {
      const int lane = int(workers_.size()) + 1;
      workers_.emplace_back([this, lane] { work(lane); });
    }
  } catch (...) {
    // No thread to be had (resource limits): the caller writes the rest itself.
  }
  policy_ = -1;  // new workers follow the caller's policy too
  return int(workers_.size());
}

// The tick thread's policy (and its changes, e.g. `--realtime` set after the server started)
// passes to the workers: a worker at normal priority would make a SCHED_FIFO tick wait for it.
// Asked of the kernel, not pthread_getschedparam, which answers from glibc's cache: a policy
// set from outside (chrt -p, sched_setscheduler on the thread id) would go unseen, and a thread
// inherits its creator's cached answer.
void FanoutPool::follow_caller_policy() noexcept {
  sched_param param{};
  const int policy = sched_getscheduler(0);
  if (policy < 0 || sched_getparam(0, &param) != 0) return;
  if (policy == policy_ && param.sched_priority == priority_) return;
  policy_ = policy;
  priority_ = param.sched_priority;
  for (auto& t : workers_) pthread_setschedparam(t.native_handle(), policy, &param);
}

int FanoutPool::run(int lanes, Job job, void* context) noexcept {
  if (lanes > 1 && int(workers_.size()) < lanes - 1) lanes = 1 + start_workers(lanes - 1);
  if (lanes <= 1) {
    job(context, 0);
    return 1;
  }
  follow_caller_policy();
  {
    std::lock_guard lock(mutex_);
    job_ = job;
    context_ = context;
    lanes_ = lanes;
    pending_ = lanes - 1;
    ++generation_;
  }
  start_.notify_all();
  job(context, 0);
  std::unique_lock lock(mutex_);
  done_.wait(lock, [&] { return pending_ == 0; });
  return lanes;
}

void FanoutPool::work(int lane) {
  pthread_setname_np(pthread_self(), "mimic-fanout");  // what ps and top show
  uint64_t seen = 0;
  std::unique_lock lock(mutex_);
  for (;;) {
    start_.wait(lock, [&] { return quit_ || generation_ != seen; });
    if (quit_) return;
    seen = generation_;
    if (lane >= lanes_) continue;
    const Job job = job_;
    void* context = context_;
    lock.unlock();
    job(context, lane);
    lock.lock();
    if (--pending_ == 0) done_.notify_one();
  }
}

}  // namespace mimic::net
