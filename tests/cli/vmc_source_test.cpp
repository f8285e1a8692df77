// `--source vmc:[HOST:]PORT` end to end: one `mimic run` sends its walking avatar as VMC
// (`--vmc`), a second one takes that VMC stream as its source; both serve their avatar, and a
// viewer of each sees the same body pose (the second within VMC's neck split), then the second
// goes stale when the first stops.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/net/client.h"
#include "free_port.h"
#include "mimic_proc.h"

namespace vmc_source_test {

namespace {

using mimic::test::endpoint_of;
using mimic::test::Proc;
using Clock = std::chrono::steady_clock;

std::unique_ptr<mimic::net::Client> viewer(const std::string& ep) {
  mimic::net::ClientOptions o;
  o.connect = ep;
  auto c = mimic::net::Client::connect(o);
  return c ? std::move(*c) : nullptr;
}

std::vector<glm::vec3> joints(const mimic::rig::Skeleton& s, const mimic::rig::Pose& p) {
  std::vector<mimic::rig::RigidTransform> fk(size_t(s.joint_count()));
  mimic::rig::forward_kinematics(s, p, fk);
  std::vector<glm::vec3> out;
  for (const auto& t : fk) out.push_back(t.translation);
  return out;
}

TEST(VmcSource, AnotherMimicsVmcOutputDrivesTheAvatar) {
  const uint16_t port = mimic::test::free_port(SOCK_DGRAM);
  const std::string target = "127.0.0.1:" + std::to_string(port);
  Proc receiver({"run", "--listen", "127.0.0.1:0", "--source", "vmc:" + target, "--duration", "60", "--quiet"});
  const std::string rx_ep = endpoint_of(receiver);
  ASSERT_FALSE(rx_ep.empty()) << receiver.err();
  Proc sender({"run", "--listen", "127.0.0.1:0", "--vmc", target, "--duration", "60", "--quiet"});
  const std::string tx_ep = endpoint_of(sender);
  ASSERT_FALSE(tx_ep.empty()) << sender.err();

  auto original = viewer(tx_ep), relayed = viewer(rx_ep);
  ASSERT_TRUE(original && relayed);
  const auto skeleton = *mimic::rig::Skeleton::build(mimic::rig::default_skeleton_desc());
  // Every frame of each, as joint positions; compared once both are in (either viewer may get
  // a pose first).
  std::vector<std::vector<glm::vec3>> sent, received;
  original->on_pose = [&](const mimic::net::RemoteAvatar& a, uint64_t) { sent.push_back(joints(skeleton, a.pose)); };
  relayed->on_pose = [&](const mimic::net::RemoteAvatar& a, uint64_t) {
    if (!(a.last.flags & mimic::net::kPoseStale)) received.push_back(joints(skeleton, a.pose));
  };
  const auto end = Clock::now() + std::chrono::seconds(30);
  while (received.size() < 130 && Clock::now() < end) {
    (void)original->run_until(Clock::now() + std::chrono::milliseconds(2));
    (void)relayed->run_until(Clock::now() + std::chrono::milliseconds(2));
  }
  for (int i = 0; i < 20; ++i) (void)original->run_until(Clock::now() + std::chrono::milliseconds(5));
  ASSERT_GE(received.size(), 130u) << receiver.err();
  int compared = 0, matched = 0;
  float worst_body = 0, worst_head = 0;
  for (size_t r = 30; r < received.size(); ++r) {  // the first ones may precede the first sent
    const auto& got = received[r];
    // The sender's frame this one came from: the nearest of its frames.
    float best_body = 1e9f, best_head = 1e9f;
    for (const auto& want : sent) {
      float body = 0, head = 0;
      for (int j = 0; j < skeleton.joint_count(); ++j) {
        const float e = glm::length(got[size_t(j)] - want[size_t(j)]);
        const bool above_neck = skeleton.joint_name(j) == "neck_upper" || skeleton.joint_name(j) == "head";
        float& worst = above_neck ? head : body;
        worst = std::max(worst, e);
      }
      if (body < best_body) {
        best_body = body;
        best_head = head;
      }
    }
    compared++;
    matched += best_body < 0.005f && best_head < 0.015f;
    worst_body = std::max(worst_body, best_body);
    worst_head = std::max(worst_head, best_head);
  }
  std::printf(
      "[ figure ] vmc: source: %d of %d frames within 5 mm of a sender's frame (head 15 mm); worst %.1f mm, head %.1f "
      "mm\n",
      matched, compared, worst_body * 1e3, worst_head * 1e3);
  // Every frame is one of the sender's, up to the wire's quantisation and VMC's neck split
  // (latest wins may drop a sender's frame before its viewer sees it: a few may find no twin).
  EXPECT_GE(matched, compared * 9 / 10) << "worst body " << worst_body << " m, head " << worst_head << " m";

  // The sender stops: the receiver keeps serving, its frames marked stale.
  sender.signal(SIGINT);
  ASSERT_EQ(sender.wait(15.0), 0);
  bool stale = false;
  relayed->on_pose = [&](const mimic::net::RemoteAvatar& a, uint64_t) {
    stale |= (a.last.flags & mimic::net::kPoseStale) != 0;
  };
  const auto until = Clock::now() + std::chrono::seconds(10);
  while (!stale && Clock::now() < until) (void)relayed->run_until(Clock::now() + std::chrono::milliseconds(5));
  EXPECT_TRUE(stale);
  receiver.signal(SIGINT);
  EXPECT_EQ(receiver.wait(15.0), 0) << receiver.err();
}

// A VMC sender that sends devices and no bones (SteamVR trackers relayed over VMC): the bones
// source says what the sender sends and how to read it, in --json's sources and on the status line.
TEST(VmcSource, ASenderOfDevicesOnlyIsToldHowToReadThem) {
  if (std::system("command -v oscsend > /dev/null") != 0) GTEST_SKIP() << "oscsend (liblo-tools) missing";
  const uint16_t port = mimic::test::free_port(SOCK_DGRAM);
  Proc run({"run", "--listen", "127.0.0.1:0", "--source", "vmc:127.0.0.1:" + std::to_string(port), "--duration", "4",
            "--quiet", "--json"});
  ASSERT_FALSE(endpoint_of(run).empty()) << run.err();
  for (int i = 0; i < 5; ++i)
    ASSERT_EQ(std::system(("oscsend 127.0.0.1 " + std::to_string(port) +
                           " /VMC/Ext/Tra/Pos sfffffff LHR-1A2B 0.1 1.0 0.2 0 0 0 1")
                              .c_str()),
              0);
  ASSERT_EQ(run.wait(30.0), 0) << run.err();
  // The summary is the last line on stdout.
  std::string out = run.out();
  while (!out.empty() && out.back() == '\n') out.pop_back();
  const std::string summary = out.substr(out.rfind('\n') + 1);
  EXPECT_NE(summary.find("T:LHR-1A2B"), std::string::npos) << summary;
  EXPECT_NE(summary.find("vmc:PORT?map=SERIAL:SEGMENT"), std::string::npos) << summary;
}

TEST(VmcSource, BadSpecsGetClearErrors) {
  Proc bad({"run", "--listen", "127.0.0.1:0", "--source", "vmc:not-a-port", "--duration", "1"});
  EXPECT_NE(bad.wait(15.0), 0);
  EXPECT_NE(bad.err().find("not-a-port"), std::string::npos) << bad.err();
}

}  // namespace

}  // namespace vmc_source_test
