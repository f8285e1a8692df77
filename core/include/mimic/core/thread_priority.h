// Realtime scheduling for the loop and the threads it waits on. Each call says whether the
// system allowed it (SCHED_FIFO needs CAP_SYS_NICE or an rtprio limit); callers report a refusal
// and go on at normal priority.
#pragma once

#include <sys/types.h>

namespace mimic {

// The calling thread at SCHED_FIFO `priority` (1-99), or back to normal scheduling for 0.
bool set_thread_fifo(int priority) noexcept;

// Every thread of process `pid` (another program, or this one's library threads) at SCHED_FIFO
// `priority`, or normal for 0. Returns how many threads took it.
int set_process_threads_fifo(pid_t pid, int priority) noexcept;

}  // namespace mimic
