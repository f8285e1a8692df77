// The status line of `mimic run` as a person sees it: on an 80-column terminal (a real pty) it
// never passes the width, so it does not wrap and scroll, and the latency shows; into a pipe or a
// log it is whole lines, one every few seconds, not two a second; the rate is per avatar.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <vector>

#include "mimic_proc.h"

extern char** environ;

namespace status_line_test {

namespace {

using Clock = std::chrono::steady_clock;

// Runs mimic with stderr on a pseudo-terminal of `columns` columns; returns what it wrote there.
std::string stderr_on_a_terminal(const std::vector<std::string>& rest, int columns, double seconds) {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
  if (master < 0 || ::grantpt(master) != 0 || ::unlockpt(master) != 0) return "";
  const int slave = ::open(::ptsname(master), O_RDWR | O_NOCTTY);
  winsize ws{};
  ws.ws_col = static_cast<unsigned short>(columns);
  ws.ws_row = 24;
  ::ioctl(slave, TIOCSWINSZ, &ws);
  std::vector<std::string> args{mimic::test::mimic_binary()};
  args.insert(args.end(), rest.begin(), rest.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&fa, slave, 2);
  pid_t pid = -1;
  const bool ok = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) == 0;
  posix_spawn_file_actions_destroy(&fa);
  ::close(slave);
  std::string text;
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (ok && Clock::now() < end) {
    pollfd p{master, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(master, buf, sizeof buf);
    if (n <= 0) break;
    text.append(buf, size_t(n));
  }
  if (ok) {
    ::kill(pid, SIGINT);
    ::waitpid(pid, nullptr, 0);
  }
  ::close(master);
  return text;
}

TEST(StatusLine, FitsAnEightyColumnTerminalAndShowsTheLatency) {
  const std::string text = stderr_on_a_terminal({"run", "--listen", "127.0.0.1:0", "--duration", "30"}, 80, 3.0);
  ASSERT_NE(text.find("fps"), std::string::npos) << text;
  int updates = 0;
  // Each rewrite starts with '\r'; the pty turns '\n' into "\r\n".
  for (size_t at = text.find('\r'); at != std::string::npos;) {
    const size_t next = text.find_first_of("\r\n", at + 1);
    const std::string update = text.substr(at + 1, next == std::string::npos ? std::string::npos : next - at - 1);
    if (update.find("fps") != std::string::npos) {
      updates++;
      EXPECT_LT(update.size(), 80u) << "'" << update << "'";
      EXPECT_NE(update.find("latency"), std::string::npos) << update;
      EXPECT_EQ(update.find("avatar(s)"), std::string::npos) << update;
    }
    at = next;
  }
  EXPECT_GE(updates, 3);
}

TEST(StatusLine, IntoAPipeItIsWholeLinesEveryFewSeconds) {
  mimic::test::Proc run(
      {"run", "--listen", "127.0.0.1:0", "--source", "sim:walk", "--source", "sim:idle", "--duration", "6"});
  ASSERT_EQ(run.wait(30.0), 0) << run.err();
  int lines = 0;
  for (size_t at = run.err().find("fps each"); at != std::string::npos; at = run.err().find("fps each", at + 1))
    lines++;
  EXPECT_GE(lines, 1) << run.err();
  EXPECT_LE(lines, 2) << run.err();  // 6 s at one line per 5 s, not 12 rewrites
  EXPECT_EQ(run.err().find('\r'), std::string::npos);
  EXPECT_NE(run.err().find("2 avatars"), std::string::npos) << run.err();
}

}  // namespace

}  // namespace status_line_test
