// Runs the built `mimic` program for end-to-end tests.
#pragma once

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

extern char** environ;

#include "test_data.h"

namespace mimic::test {

struct Outcome {
  int status = -1;     // exit status, −1 when it did not exit normally
  std::string output;  // stdout, and stderr unless asked to leave it out
};

// Runs a shell command line: its exit status and what it wrote on stdout (redirect stderr in
// `command` to have it too).
inline Outcome run_shell(const std::string& command) {
  Outcome r;
  FILE* p = ::popen(command.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// `args` is a shell fragment (quote paths). With stdout_only, stderr goes to /dev/null.
inline Outcome run_mimic(const std::string& args, bool stdout_only = false) {
  std::string cmd = "'";  // built by appending: GCC 12 warns falsely on chained + (-Wrestrict)
  cmd.append(mimic_binary()).append("' ").append(args).append(stdout_only ? " 2>/dev/null" : " 2>&1");
  return run_shell(cmd);
}

// A program running in the background (e.g. `mimic sim flock`) whose stdout, and optionally
// stderr, the test reads line by line; killed when it goes out of scope.
struct Child {
  pid_t pid = -1;
  FILE* out = nullptr;

  explicit Child(const std::vector<std::string>& args, bool capture_stderr = false) {
    int fds[2];
    if (::pipe(fds) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    if (capture_stderr) posix_spawn_file_actions_adddup2(&fa, fds[1], 2);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0) pid = -1;
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    out = ::fdopen(fds[0], "r");
  }
  std::string line() {
    char buf[512];
    if (!out || !std::fgets(buf, sizeof buf, out)) return {};
    std::string s(buf);
    if (!s.empty() && s.back() == '\n') s.pop_back();
    return s;
  }
  std::string rest() {
    std::string s;
    char buf[512];
    while (out && std::fgets(buf, sizeof buf, out)) s += buf;
    return s;
  }
  int wait() {
    int status = 0;
    if (pid > 0) ::waitpid(pid, &status, 0);
    pid = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  ~Child() {
    if (pid > 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
    if (out) std::fclose(out);
  }
};

}  // namespace mimic::test
