// VMC output checked against a real OSC receiver: liblo's oscdump, spawned on a loopback port.
#include <gtest/gtest.h>

#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <map>
#include <sstream>
#include <thread>

#include "mimic/net/vmc.h"
#include "free_port.h"

extern char** environ;

namespace mimic::net::vmc_test {
namespace {

uint16_t free_udp_port() { return ::mimic::test::free_port(SOCK_DGRAM); }

// oscdump as a child process with its stdout on a pipe.
class OscDump {
 public:
  explicit OscDump(uint16_t port) {
    int fds[2];
    if (::pipe(fds) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    const std::string p = std::to_string(port);
    char* argv[] = {const_cast<char*>("oscdump"), const_cast<char*>("-L"), const_cast<char*>(p.c_str()), nullptr};
    ok_ = posix_spawnp(&pid_, "oscdump", &fa, nullptr, argv, environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    in_ = ::fdopen(fds[0], "r");
  }
  ~OscDump() {
    if (ok_) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
    if (in_) ::fclose(in_);
  }
  bool ok() const { return ok_ && in_; }
  // One line of output (blocking); empty at EOF.
  std::string line() {
    char buf[4096];
    if (!std::fgets(buf, sizeof buf, in_)) return "";
    return buf;
  }

 private:
  pid_t pid_ = -1;
  bool ok_ = false;
  FILE* in_ = nullptr;
};

struct OscLine {
  std::string address, types;
  std::vector<std::string> args;
};

// "<timetag> /VMC/Ext/Bone/Pos sfffffff "Hips" 1.000000 ..." (bundled messages carry the bundle's
// time tag first).
OscLine parse(const std::string& text) {
  std::istringstream is(text);
  OscLine l;
  std::string first;
  is >> first;
  if (!first.empty() && first[0] != '/')
    is >> l.address;
  else
    l.address = first;
  is >> l.types;
  std::string a;
  while (is >> a) {
    if (a.size() >= 2 && a.front() == '"' && a.back() == '"') a = a.substr(1, a.size() - 2);
    l.args.push_back(a);
  }
  return l;
}

// Reads oscdump until a whole frame (every bone, root, OK and T) has been seen.
struct DumpedFrame {
  std::map<std::string, OscLine> bones;
  OscLine root, ok, t;
  std::vector<double> times;  // every /VMC/Ext/T seen
};
DumpedFrame read_frame(OscDump& dump, size_t bones_expected, size_t times_wanted = 1) {
  DumpedFrame f;
  while (f.bones.size() < bones_expected || f.ok.address.empty() || f.times.size() < times_wanted ||
         f.root.address.empty()) {
    const std::string s = dump.line();
    if (s.empty()) break;
    const OscLine l = parse(s);
    if (l.address == "/VMC/Ext/Bone/Pos" && !l.args.empty())
      f.bones[l.args[0]] = l;
    else if (l.address == "/VMC/Ext/Root/Pos")
      f.root = l;
    else if (l.address == "/VMC/Ext/OK")
      f.ok = l;
    else if (l.address == "/VMC/Ext/T") {
      f.t = l;
      if (!l.args.empty()) f.times.push_back(std::stod(l.args[0]));
    }
  }
  return f;
}

// Two consecutive free UDP ports (avatar i goes to port + i).
uint16_t free_udp_port_pair() {
  for (int tries = 0; tries < 50; ++tries) {
    const uint16_t p = free_udp_port();
    if (p == 65535) continue;
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(uint16_t(p + 1));
    const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(fd);
    if (ok) return p;
  }
  return 0;
}

TEST(Vmc, OscdumpReceivesEveryBoneRootOkAndTime) {
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(sk);
  const uint16_t port = free_udp_port();
  OscDump dump(port);
  ASSERT_TRUE(dump.ok()) << "oscdump (liblo-tools) must be installed";
  auto sender = VmcSender::open("127.0.0.1:" + std::to_string(port));
  ASSERT_TRUE(sender) << sender.error().what();
  ASSERT_TRUE((*sender)->add_avatar(*sk));

  rig::Pose pose = sk->zero_pose();
  pose.root_position_m = {0.25f, 0.9f, -0.5f};
  const float abd = -75.0f * 3.14159265f / 180.0f;
  pose.dof_rad[size_t(sk->find_dof("l_shoulder_abduction"))] = abd;
  pose.dof_rad[size_t(sk->find_dof("r_knee_flexion"))] = 0.5f;

  // oscdump may not be listening yet: keep sending until it has reported whole frames. The
  // capture times are Unix-like seconds, 0.25 s apart; /VMC/Ext/T counts from the first.
  std::atomic<bool> done{false};
  std::thread send([&] {
    for (int i = 0; i < 500 && !done; ++i) {
      (*sender)->send(0, pose, 1.7e9 + 0.25 * i);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  const size_t expected = vmc_bone_map(*sk).size();
  DumpedFrame f = read_frame(dump, expected, 3);
  done = true;
  send.join();
  auto& bones = f.bones;

  EXPECT_EQ(expected, 22u);
  for (const char* b :
       {"Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
        "LeftHand", "RightUpperArm", "LeftUpperLeg", "RightLowerLeg", "LeftFoot", "RightToes"})
    EXPECT_TRUE(bones.count(b)) << b;
  ASSERT_EQ(f.root.types, "sfffffff");
  EXPECT_EQ(f.root.args[0], "root");
  ASSERT_EQ(f.ok.types, "i");
  EXPECT_EQ(f.ok.args[0], "1");
  ASSERT_EQ(f.t.types, "f");
  // Seconds since the stream started: small, a multiple of the 0.25 s between frames, rising.
  ASSERT_GE(f.times.size(), 3u);
  for (size_t i = 0; i < f.times.size(); ++i) {
    EXPECT_LT(f.times[i], 125.0);
    EXPECT_NEAR(std::remainder(f.times[i], 0.25), 0.0, 1e-4) << f.times[i];
    if (i > 0) {
      EXPECT_NEAR(f.times[i] - f.times[i - 1], 0.25, 1e-4);
    }
  }

  // Hips carry the body's world position, mirrored into Unity's left-handed frame.
  const OscLine& hips = bones["Hips"];
  ASSERT_EQ(hips.types, "sfffffff");
  EXPECT_NEAR(std::stod(hips.args[1]), -0.25, 1e-5);
  EXPECT_NEAR(std::stod(hips.args[2]), 0.9, 1e-5);
  EXPECT_NEAR(std::stod(hips.args[3]), -0.5, 1e-5);
  // Left upper arm: a rotation about Mimic's +Z by abd; in Unity (x, −y, −z, w).
  const OscLine& arm = bones["LeftUpperArm"];
  EXPECT_NEAR(std::stod(arm.args[4]), 0.0, 1e-5);
  EXPECT_NEAR(std::stod(arm.args[6]), -std::sin(abd / 2), 1e-5);
  EXPECT_NEAR(std::stod(arm.args[7]), std::cos(abd / 2), 1e-5);
  // An untouched bone has the identity rotation.
  const OscLine& hand = bones["LeftHand"];
  EXPECT_NEAR(std::stod(hand.args[7]), 1.0, 1e-5);
}

// Every avatar is sent: avatar i to port + i, each a complete VMC stream of its own.
TEST(Vmc, EveryAvatarOnItsOwnPort) {
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(sk);
  const uint16_t port = free_udp_port_pair();
  ASSERT_NE(port, 0);
  OscDump dump0(port), dump1(uint16_t(port + 1));
  ASSERT_TRUE(dump0.ok() && dump1.ok());
  auto sender = VmcSender::open("127.0.0.1:" + std::to_string(port));
  ASSERT_TRUE(sender);
  ASSERT_TRUE((*sender)->add_avatar(*sk));
  ASSERT_TRUE((*sender)->add_avatar(*sk));
  EXPECT_EQ((*sender)->avatar_count(), 2u);
  EXPECT_EQ((*sender)->send(2, sk->zero_pose(), 0.0), 0u);  // never added
  rig::Pose a = sk->zero_pose(), b = sk->zero_pose();
  a.root_position_m = {1.0f, 0.9f, 0.0f};
  b.root_position_m = {-2.0f, 0.9f, 0.0f};
  std::atomic<bool> done{false};
  std::thread send([&] {
    for (int i = 0; i < 500 && !done; ++i) {
      (*sender)->send(0, a, 0.01 * i);
      (*sender)->send(1, b, 0.01 * i);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  const size_t expected = vmc_bone_map(*sk).size();
  DumpedFrame f0 = read_frame(dump0, expected), f1 = read_frame(dump1, expected);
  done = true;
  send.join();
  ASSERT_EQ(f0.bones.size(), expected);
  ASSERT_EQ(f1.bones.size(), expected);
  EXPECT_NEAR(std::stod(f0.bones["Hips"].args[1]), -1.0, 1e-5);  // x mirrored
  EXPECT_NEAR(std::stod(f1.bones["Hips"].args[1]), 2.0, 1e-5);

  auto last = VmcSender::open("127.0.0.1:65535");
  ASSERT_TRUE(last);
  EXPECT_TRUE((*last)->add_avatar(*sk));
  EXPECT_FALSE((*last)->add_avatar(*sk));  // port 65536 does not exist
}

// The elements of each bundle tile it exactly; returns the message addresses in order.
std::vector<std::string> bundle_addresses(const uint8_t* data, size_t size) {
  std::vector<std::string> addresses;
  EXPECT_GE(size, 16u);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(data)), "#bundle");
  EXPECT_EQ(size % 4, 0u);
  size_t pos = 16;
  while (pos + 4 <= size) {
    const uint32_t n =
        uint32_t(data[pos]) << 24 | uint32_t(data[pos + 1]) << 16 | uint32_t(data[pos + 2]) << 8 | data[pos + 3];
    EXPECT_EQ(n % 4, 0u);
    addresses.emplace_back(reinterpret_cast<const char*>(data + pos + 4));
    pos += 4 + n;
  }
  EXPECT_EQ(pos, size);
  return addresses;
}

TEST(Vmc, BundlesStayUnderTheMtuAndCloseWithOkAndTime) {
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(sk);
  VmcEncoder enc(*sk);
  std::vector<uint8_t> out;
  for (const size_t limit : {kVmcMaxBundleBytes, size_t(200), size_t(100000)}) {
    const VmcBundles b = enc.encode(sk->rest_pose(), 1.0, out, limit);
    ASSERT_GE(b.count, 1u);
    EXPECT_EQ(b.end[b.count - 1], out.size());
    std::vector<std::string> all;
    size_t begin = 0;
    for (size_t i = 0; i < b.count; ++i) {
      EXPECT_LE(b.end[i] - begin, limit);
      const auto a = bundle_addresses(out.data() + begin, b.end[i] - begin);
      EXPECT_FALSE(a.empty());
      all.insert(all.end(), a.begin(), a.end());
      begin = b.end[i];
    }
    ASSERT_EQ(all.size(), 1 + 22 + 2u) << "limit " << limit;
    EXPECT_EQ(all.front(), "/VMC/Ext/Root/Pos");
    EXPECT_EQ(all[all.size() - 2], "/VMC/Ext/OK");
    EXPECT_EQ(all.back(), "/VMC/Ext/T");
    const size_t want_min = limit == kVmcMaxBundleBytes ? 2 : limit == 200 ? 10 : 1;
    const size_t want_max = limit == kVmcMaxBundleBytes ? 2 : limit == 200 ? 25 : 1;
    EXPECT_GE(b.count, want_min);
    EXPECT_LE(b.count, want_max);
  }
  // Re-encoding reuses the buffer.
  enc.encode(sk->rest_pose(), 1.0, out);
  const uint8_t* data = out.data();
  enc.encode(sk->rest_pose(), 2.0, out);
  EXPECT_EQ(out.data(), data);
}

// On the wire: one datagram per bundle, none over the limit.
TEST(Vmc, DatagramsOnLoopbackStayUnderTheLimit) {
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(sk);
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  auto sender = VmcSender::open("127.0.0.1:" + std::to_string(ntohs(a.sin_port)));
  ASSERT_TRUE(sender);
  ASSERT_TRUE((*sender)->add_avatar(*sk));
  const size_t sent = (*sender)->send(0, sk->rest_pose(), 5.0);
  EXPECT_GT(sent, kVmcMaxBundleBytes);
  size_t got = 0, datagrams = 0;
  std::vector<uint8_t> buf(65536);
  timeval tv{1, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  while (got < sent) {
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n <= 0) break;
    EXPECT_LE(size_t(n), kVmcMaxBundleBytes);
    EXPECT_FALSE(bundle_addresses(buf.data(), size_t(n)).empty());
    got += size_t(n);
    ++datagrams;
  }
  ::close(fd);
  EXPECT_EQ(got, sent);
  EXPECT_EQ(datagrams, 2u);
}

}  // namespace
}  // namespace mimic::net::vmc_test
