// Realtime scheduling for the loop and the threads it waits on. Each call says whether the
// system allowed it (SCHED_FIFO needs CAP_SYS_NICE or an rtprio limit); callers report a refusal
// and go on at normal priority.
#pragma once

#include <sys/types.h>

namespace mimic {

// While held, asks the kernel (PM QoS, /dev/cpu_dma_latency) to keep every CPU out of idle states
// slower than `max_wakeup_us` to leave: the loop's CPU, napping between passes, wakes in
// microseconds and finds its caches as it left them (measured: the solve and the deform a
// quarter faster at 100 Hz). The request lasts as long as the object; writing the device needs
// root. ok() says whether the kernel took it; callers report a refusal and go on.
class CpuWakeupLatency {
 public:
  explicit CpuWakeupLatency(int max_wakeup_us, const char* device = "/dev/cpu_dma_latency") noexcept;
  ~CpuWakeupLatency();
  CpuWakeupLatency(const CpuWakeupLatency&) = delete;
  CpuWakeupLatency& operator=(const CpuWakeupLatency&) = delete;
  bool ok() const noexcept { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

// The calling thread at SCHED_FIFO `priority` (1-99), or back to normal scheduling for 0.
bool set_thread_fifo(int priority) noexcept;

// Every thread of process `pid` (another program, or this one's library threads) at SCHED_FIFO
// `priority`, or normal for 0. Returns how many threads took it.
int set_process_threads_fifo(pid_t pid, int priority) noexcept;

}  // namespace mimic
