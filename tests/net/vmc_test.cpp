// VMC output checked against a real OSC receiver: liblo's oscdump, spawned on a loopback port.
#include <gtest/gtest.h>

#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <map>
#include <sstream>
#include <thread>

#include "mimic/net/vmc.h"

extern char** environ;

namespace mimic::net {
namespace {

uint16_t free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

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
  if (!first.empty() && first[0] != '/') is >> l.address;
  else l.address = first;
  is >> l.types;
  std::string a;
  while (is >> a) {
    if (a.size() >= 2 && a.front() == '"' && a.back() == '"') a = a.substr(1, a.size() - 2);
    l.args.push_back(a);
  }
  return l;
}

TEST(Vmc, OscdumpReceivesEveryBoneRootOkAndTime) {
  auto sk = avatar::Skeleton::build(avatar::default_skeleton_desc());
  ASSERT_TRUE(sk);
  const uint16_t port = free_udp_port();
  OscDump dump(port);
  ASSERT_TRUE(dump.ok()) << "oscdump (liblo-tools) must be installed";
  auto sender = VmcSender::open("127.0.0.1:" + std::to_string(port), *sk);
  ASSERT_TRUE(sender) << sender.error().what();

  avatar::Pose pose = sk->zero_pose();
  pose.root_position_m = {0.25f, 0.9f, -0.5f};
  const float abd = -75.0f * 3.14159265f / 180.0f;
  pose.dof_rad[size_t(sk->find_dof("l_shoulder_abduction"))] = abd;
  pose.dof_rad[size_t(sk->find_dof("r_knee_flexion"))] = 0.5f;

  // oscdump may not be listening yet: keep sending until it has reported a whole frame.
  std::atomic<bool> done{false};
  std::thread send([&] {
    for (int i = 0; i < 500 && !done; ++i) {
      (*sender)->send(pose, 12.5);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  std::map<std::string, OscLine> bones;
  OscLine root, ok, t;
  const size_t expected = vmc_bone_map(*sk).size();
  while (bones.size() < expected || ok.address.empty() || t.address.empty() || root.address.empty()) {
    const std::string s = dump.line();
    if (s.empty()) break;
    const OscLine l = parse(s);
    if (l.address == "/VMC/Ext/Bone/Pos" && !l.args.empty()) bones[l.args[0]] = l;
    else if (l.address == "/VMC/Ext/Root/Pos") root = l;
    else if (l.address == "/VMC/Ext/OK") ok = l;
    else if (l.address == "/VMC/Ext/T") t = l;
  }
  done = true;
  send.join();

  EXPECT_EQ(expected, 22u);
  for (const char* b : {"Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm",
                        "LeftLowerArm", "LeftHand", "RightUpperArm", "LeftUpperLeg", "RightLowerLeg", "LeftFoot",
                        "RightToes"})
    EXPECT_TRUE(bones.count(b)) << b;
  ASSERT_EQ(root.types, "sfffffff");
  EXPECT_EQ(root.args[0], "root");
  ASSERT_EQ(ok.types, "i");
  EXPECT_EQ(ok.args[0], "1");
  ASSERT_EQ(t.types, "f");
  EXPECT_NEAR(std::stod(t.args[0]), 12.5, 1e-4);

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

TEST(Vmc, BundleIsAlignedAndSized) {
  auto sk = avatar::Skeleton::build(avatar::default_skeleton_desc());
  ASSERT_TRUE(sk);
  VmcEncoder enc(*sk);
  std::vector<uint8_t> out;
  enc.encode(sk->rest_pose(), 1.0, out);
  ASSERT_GE(out.size(), 16u);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(out.data())), "#bundle");
  EXPECT_EQ(out.size() % 4, 0u);
  // Walk the elements: sizes must tile the bundle exactly.
  size_t pos = 16, elements = 0;
  while (pos < out.size()) {
    const uint32_t n = uint32_t(out[pos]) << 24 | uint32_t(out[pos + 1]) << 16 | uint32_t(out[pos + 2]) << 8 | out[pos + 3];
    ASSERT_EQ(n % 4, 0u);
    pos += 4 + n;
    elements++;
  }
  EXPECT_EQ(pos, out.size());
  EXPECT_EQ(elements, 1 + 22 + 2u);
  // Re-encoding reuses the buffer.
  const uint8_t* data = out.data();
  enc.encode(sk->rest_pose(), 2.0, out);
  EXPECT_EQ(out.data(), data);
}

}  // namespace
}  // namespace mimic::net
