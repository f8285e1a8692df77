#include "mimic/core/thread_priority.h"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace mimic {

namespace {
sched_param param_of(int priority) noexcept {
  sched_param p{};
  p.sched_priority = priority;
  return p;
}
int policy_of(int priority) noexcept { return priority > 0 ? SCHED_FIFO : SCHED_OTHER; }
}  // namespace

CpuWakeupLatency::CpuWakeupLatency(int max_wakeup_us, const char* device) noexcept
    : fd_(::open(device, O_WRONLY | O_CLOEXEC)) {
  // The device takes the bound as a binary 32-bit integer and keeps it while the file is open.
  const int32_t value = max_wakeup_us < 0 ? 0 : max_wakeup_us;
  if (fd_ >= 0 && ::write(fd_, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) {
    ::close(fd_);
    fd_ = -1;
  }
}

CpuWakeupLatency::~CpuWakeupLatency() {
  if (fd_ >= 0) ::close(fd_);
}

bool set_thread_fifo(int priority) noexcept {
  const sched_param p = param_of(priority);
  return pthread_setschedparam(pthread_self(), policy_of(priority), &p) == 0;
}

int set_process_threads_fifo(pid_t pid, int priority) noexcept {
  const sched_param p = param_of(priority);
  int taken = 0;
  std::error_code ec;
  std::filesystem::directory_iterator tasks("/proc/" + std::to_string(pid) + "/task", ec);
  for (; !ec && tasks != std::filesystem::directory_iterator(); tasks.increment(ec)) {
    const long tid = std::strtol(tasks->path().filename().c_str(), nullptr, 10);
    if (tid > 0 && sched_setscheduler(static_cast<pid_t>(tid), policy_of(priority), &p) == 0) ++taken;
  }
  return taken;
}

}  // namespace mimic
