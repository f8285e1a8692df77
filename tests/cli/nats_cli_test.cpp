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

#include "mimic_proc.h"
#include "nats_broker.h"
#include "test_data.h"

namespace {

using mimic::test::Proc;

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
