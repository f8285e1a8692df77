// End to end with a real nats-server: `mimic run --nats` refused on wrong credentials, serving
// its local listeners while the broker is down and joining it when it comes up (status line),
// `mimic relay` and `mimic subscribe --connect nats://...` taking the scene from the broker.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "nats_broker.h"
#include "test_data.h"

namespace {

class Proc {
 public:
  explicit Proc(const std::vector<std::string>& rest) {
    std::vector<std::string> args{mimic::test::mimic_binary()};
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
  // Collects output until stderr holds `text` (true) or the timeout passes (false).
  bool wait_for_err(const std::string& text, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (err_text_.find(text) == std::string::npos) {
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
        drain(0);
        drain(0);
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
    }
    return -1;
  }
  const std::string& out() const { return out_text_; }
  const std::string& err() const { return err_text_; }

 private:
  void drain(int timeout_ms) {
    pollfd p[2] = {{out_, POLLIN, 0}, {err_, POLLIN, 0}};
    if (::poll(p, 2, timeout_ms) <= 0) return;
    char buf[8192];
    if (p[0].revents & POLLIN) {
      const ssize_t n = ::read(out_, buf, sizeof buf);
      if (n > 0) out_text_.append(buf, size_t(n));
    }
    if (p[1].revents & POLLIN) {
      const ssize_t n = ::read(err_, buf, sizeof buf);
      if (n > 0) err_text_.append(buf, size_t(n));
    }
  }
  pid_t pid_ = -1;
  bool ok_ = false, exited_ = false;
  int out_ = -1, err_ = -1;
  std::string out_text_, err_text_;
};

std::string endpoint_of(Proc& p) {
  const std::string line = p.first_line(10.0);
  const std::string prefix = "serving on ";
  if (line.rfind(prefix, 0) != 0) return "";
  const size_t end = line.find(';');
  return line.substr(prefix.size(), end == std::string::npos ? std::string::npos : end - prefix.size());
}

nlohmann::json last_json(const std::string& out) {
  const auto start = out.rfind("\n{");
  const std::string text = start == std::string::npos ? out : out.substr(start + 1);
  return nlohmann::json::parse(text, nullptr, false);
}

// A build configured with MIMIC_WITH_NATS=OFF says so; nothing to test then.
bool built_with_nats() {
  Proc probe({"run", "--listen", "127.0.0.1:0", "--nats", "nats://127.0.0.1:1", "--duration", "0.1", "--quiet"});
  probe.wait(10.0);
  return probe.err().find("no NATS support") == std::string::npos;
}

#define REQUIRE_NATS_SERVER()                                                                        \
  do {                                                                                               \
    if (!built_with_nats()) GTEST_SKIP() << "built without NATS (MIMIC_WITH_NATS=OFF)";              \
    ASSERT_FALSE(mimic::test::nats_server_binary().empty()) << "nats-server missing: run scripts/setup.sh"; \
  } while (0)

TEST(NatsCli, WrongCredentialsRefusedWithAClearMessage) {
  REQUIRE_NATS_SERVER();
  mimic::test::NatsBroker broker;
  broker.configure("auth", {"mimic", "s3cret", ""});
  ASSERT_TRUE(broker.start());
  // Credentials come from the environment only.
  ::setenv("MIMIC_NATS_USER", "mimic", 1);
  ::setenv("MIMIC_NATS_PASSWORD", "wrong", 1);
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", broker.url(), "--duration", "5", "--quiet"});
  const int status = run.wait(15.0);
  ::unsetenv("MIMIC_NATS_USER");
  ::unsetenv("MIMIC_NATS_PASSWORD");
  EXPECT_NE(status, 0);
  EXPECT_NE(run.err().find("refused the credentials"), std::string::npos) << run.err();
  EXPECT_EQ(run.out().find("serving on"), std::string::npos) << "refused before serving anything";
}

TEST(NatsCli, RunServesLocallyWhileTheBrokerIsDownThenJoinsItRelayAndSubscribeSeeTheScene) {
  REQUIRE_NATS_SERVER();
  mimic::test::NatsBroker broker;
  broker.configure("late");  // nothing listens on its port yet
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", broker.url(), "--scene", "stage", "--nats-name", "hostA",
            "--duration", "14", "--json"});
  ASSERT_TRUE(run.ok());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  // The local listener serves meanwhile.
  Proc local({"subscribe", "--connect", ep, "--count", "30", "--json"});
  ASSERT_EQ(local.wait(15.0), 0) << local.err();
  EXPECT_EQ(last_json(local.out())["frames"], 30);
  // The status line says the broker is away before it comes (it is redrawn twice a second).
  ASSERT_TRUE(run.wait_for_err("nats DOWN: local only", 5.0)) << run.err();

  ASSERT_TRUE(broker.start());
  Proc relay({"relay", "--nats", broker.url(), "--scene", "stage", "--listen", "127.0.0.1:0", "--duration", "10",
              "--json", "--quiet"});
  const std::string relay_ep = endpoint_of(relay);
  ASSERT_FALSE(relay_ep.empty()) << relay.err();
  Proc via_relay({"subscribe", "--connect", relay_ep, "--count", "60", "--json"});
  ASSERT_EQ(via_relay.wait(20.0), 0) << via_relay.err();
  const auto j = last_json(via_relay.out());
  EXPECT_EQ(j["frames"], 60);
  EXPECT_EQ(j["avatars"], 1);
  EXPECT_EQ(j["models"], 1);
  Proc direct({"subscribe", "--connect", broker.url() + "/stage", "--count", "60", "--json"});
  ASSERT_EQ(direct.wait(20.0), 0) << direct.err();
  EXPECT_EQ(last_json(direct.out())["frames"], 60);

  run.signal(SIGINT);
  ASSERT_EQ(run.wait(10.0), 0) << run.err();
  // The status line said so while the broker was away, and after.
  EXPECT_NE(run.err().find("not reachable: serving the local listeners"), std::string::npos) << run.err();
  EXPECT_NE(run.err().find("nats DOWN: local only"), std::string::npos);
  EXPECT_NE(run.err().find("nats up"), std::string::npos);
  const auto summary = last_json(run.out());
  EXPECT_GT(summary["nats"]["frames"].get<double>(), 60.0) << run.out();
  EXPECT_GT(summary["nats"]["frames_dropped"].get<double>(), 0.0) << "frames of the outage are dropped, not queued";
  // A clean leave takes the avatar out of the scene: the relay's viewers see it go.
  relay.signal(SIGINT);
  ASSERT_EQ(relay.wait(10.0), 0);
  const auto rj = last_json(relay.out());
  EXPECT_EQ(rj["nats"]["avatars"], 0) << relay.out();
  EXPECT_EQ(rj["nats"]["rejected"], 0);
}

}  // namespace
