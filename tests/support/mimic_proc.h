// A child `mimic` with stdout and stderr on pipes, for end-to-end tests that talk to it while
// it runs (read its first line, wait for a line on stderr, signal it, wait for its exit).
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <vector>

#include "test_data.h"

extern char** environ;

namespace mimic::test {

class Proc {
 public:
  // `wrapper`: a program that runs mimic as its argument (e.g. {"/usr/bin/prlimit", "--nofile=256:256"}).
  explicit Proc(const std::vector<std::string>& rest, const std::vector<std::string>& wrapper = {}) {
    std::vector<std::string> args = wrapper;
    args.push_back(mimic_binary());
    for (const auto& a : rest) args.push_back(a);
    int out[2], err[2];
    if (::pipe(out) != 0 || ::pipe(err) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
    posix_spawn_file_actions_adddup2(&fa, err[1], 2);
    posix_spawn_file_actions_addclose(&fa, out[0]);
    posix_spawn_file_actions_addclose(&fa, err[0]);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ok_ = posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    ::close(out[1]);
    ::close(err[1]);
    out_ = out[0];
    err_ = err[0];
  }
  ~Proc() {
    if (ok_ && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    ::close(out_);
    ::close(err_);
  }
  bool ok() const { return ok_; }
  pid_t pid() const { return pid_; }
  void signal(int sig) { ::kill(pid_, sig); }

  // First stdout line (up to timeout).
  std::string first_line(double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      if (auto nl = out_text_.find('\n'); nl != std::string::npos) return out_text_.substr(0, nl);
      drain(50);
    }
    return "";
  }
  // Collects output until stderr holds `text` after byte `from` (true) or the timeout passes.
  bool wait_for_err(const std::string& text, double timeout_s, size_t from = 0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (err_text_.find(text, from) == std::string::npos) {
      if (std::chrono::steady_clock::now() >= end) return false;
      drain(20);
    }
    return true;
  }
  // Collects output until stdout holds `text` after byte `from` (true) or the timeout passes.
  bool wait_for_out(const std::string& text, double timeout_s, size_t from = 0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (out_text_.find(text, from) == std::string::npos) {
      if (std::chrono::steady_clock::now() >= end) return false;
      drain(20);
    }
    return true;
  }
  // Waits for exit (collecting output); the exit code, or -1 on timeout.
  int wait(double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      drain(20);
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        // Everything it wrote, to the end of both pipes (a chatty child leaves more than one
        // read's worth); bounded, should a grandchild hold the pipes open and keep writing.
        for (int i = 0; i < 4096 && drain(0) > 0; ++i) {}
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
    }
    return -1;
  }
  const std::string& out() const { return out_text_; }
  const std::string& err() const { return err_text_; }

 private:
  // Reads what is waiting (up to one chunk per pipe); the bytes read.
  size_t drain(int timeout_ms) {
    pollfd p[2] = {{out_, POLLIN, 0}, {err_, POLLIN, 0}};
    if (::poll(p, 2, timeout_ms) <= 0) return 0;
    char buf[8192];
    size_t got = 0;
    if (p[0].revents & POLLIN) {
      const ssize_t n = ::read(out_, buf, sizeof buf);
      if (n > 0) {
        out_text_.append(buf, size_t(n));
        got += size_t(n);
      }
    }
    if (p[1].revents & POLLIN) {
      const ssize_t n = ::read(err_, buf, sizeof buf);
      if (n > 0) {
        err_text_.append(buf, size_t(n));
        got += size_t(n);
      }
    }
    return got;
  }
  pid_t pid_ = -1;
  bool ok_ = false, exited_ = false;
  int out_ = -1, err_ = -1;
  std::string out_text_, err_text_;
};

// The endpoint a `mimic run` or `mimic relay` serves on, from its first line ("serving on
// HOST:PORT[; ...]"); empty when it did not say so in time.
inline std::string endpoint_of(Proc& p, double timeout_s = 20.0) {
  const std::string line = p.first_line(timeout_s);
  const std::string prefix = "serving on ";
  if (line.rfind(prefix, 0) != 0) return "";
  const size_t end = line.find(';');
  return line.substr(prefix.size(), end == std::string::npos ? std::string::npos : end - prefix.size());
}

}  // namespace mimic::test
