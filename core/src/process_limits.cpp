#include "mimic/core/process_limits.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>

namespace mimic {

size_t descriptor_limit() noexcept {
  rlimit r{};
  if (getrlimit(RLIMIT_NOFILE, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return size_t(1) << 20;
  return size_t(r.rlim_cur);
}

size_t raise_descriptor_limit() noexcept {
  rlimit r{};
  if (getrlimit(RLIMIT_NOFILE, &r) == 0 && r.rlim_cur < r.rlim_max) {
    r.rlim_cur = r.rlim_max;
    (void)setrlimit(RLIMIT_NOFILE, &r);
  }
  return descriptor_limit();
}

bool raise_thread_nice(int nice) noexcept {
  // On Linux, PRIO_PROCESS with a thread id sets that thread's nice value alone.
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (errno == 0 && now <= nice) return true;
  return setpriority(PRIO_PROCESS, tid, nice) == 0;
}

}  // namespace mimic
