// A tick's writes shared by several threads (ServerOptions::fanout_threads): every subscriber,
// whichever thread writes it and whatever it asked for (POSE or lean frames, TCP or UDP), gets
// every frame in order; a stalled one loses only its own frames and its stream stays whole; the
// workers run at the publishing thread's scheduling policy.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>

#include <filesystem>
#include <fstream>

#include "mimic/rig/motion.h"
#include "mimic/net/pose_stream.h"
#include "net_test_support.h"

namespace mimic::net::parallel_fanout_test {
namespace {

using namespace test;

constexpr uint16_t kDofs = 52;

ServerOptions shared_fanout() {
  ServerOptions o;
  o.fanout_threads = 3;
  o.fanout_parallel_from = 2;  // every tick with two or more subscribers to write
  return o;
}

// A server with walking local avatars and subscribers (Client), ticks published as one batch.
class Scene {
 public:
  explicit Scene(const ServerOptions& opt) : st_(opt) {
    auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
    EXPECT_TRUE(sk);
    skeleton_ = std::move(*sk);
    EXPECT_EQ(skeleton_.dof_count(), kDofs);
    auto walk = rig::make_builtin_motion("walk", skeleton_);
    EXPECT_TRUE(walk);
    walk_ = std::move(*walk);
  }
  ServerThread& st() { return st_; }
  const std::vector<uint16_t>& ids() const { return ids_; }
  std::vector<Client*>& subscribers() { return subs_; }

  void add_avatars(int n) {
    for (int i = 0; i < n; ++i)
      ids_.push_back(st_.call([&] { return *st_.server().add_avatar("w" + std::to_string(i), kDofs, "m"); }));
  }
  // Subscriber i asks for what `options(i)` says; returns when every one holds every model.
  void join(int n, const std::function<void(int, ClientOptions&)>& options = {}) {
    for (int i = 0; i < n; ++i) {
      ClientOptions o;
      o.connect = st_.endpoint();
      if (options) options(i, o);
      auto c = Client::connect(o);
      ASSERT_TRUE(c) << c.error().what();
      subs_.push_back(c->get());
      owned_.push_back(std::move(*c));
      udp_.push_back(o.udp);
    }
    ASSERT_TRUE(pump(subs_, [&] {
      for (size_t i = 0; i < subs_.size(); ++i)
        if (subs_[i]->avatars().size() != ids_.size() || (udp_[i] && !subs_[i]->udp_active())) return false;
      return true;
    }));
  }
  // One tick: every avatar's frame `seq` in one batch on the server's thread; then every
  // subscriber takes it before the next (latest wins would otherwise merge two).
  void tick(uint32_t seq) {
    st_.call([&] {
      std::vector<uint8_t> packet(pose_packet_bytes(kDofs));
      rig::Pose pose = skeleton_.zero_pose();
      st_.server().begin_batch();
      for (size_t i = 0; i < ids_.size(); ++i) {
        walk_->sample(double(seq) / 90.0 + 0.3 * double(i), pose);
        encode_pose({ids_[i], 0, seq, wall_clock_us()}, pose, packet);
        EXPECT_EQ(st_.server().publish_pose(ids_[i], packet), Reject::ok);
      }
      st_.server().end_batch();
    });
    ASSERT_TRUE(pump(subs_, [&] {
      for (auto* c : subs_)
        if (c->stats().frames < uint64_t(seq) * ids_.size()) return false;
      return true;
    })) << seq;
  }

 private:
  ServerThread st_;
  rig::Skeleton skeleton_;
  std::unique_ptr<rig::Motion> walk_;
  std::vector<uint16_t> ids_;
  std::vector<std::unique_ptr<Client>> owned_;
  std::vector<Client*> subs_;
  std::vector<bool> udp_;  // asked for datagrams
};

TEST(ParallelFanout, EverySubscriberGetsEveryFrameWhicheverThreadWritesIt) {
  Scene scene(shared_fanout());
  EXPECT_EQ(scene.st().server().fanout_threads(), 3);
  scene.add_avatars(3);
  // Twelve subscribers, every kind, spread over the three threads.
  scene.join(12, [](int i, ClientOptions& o) {
    o.lean = i % 2 == 0;
    o.udp = i % 3 == 0;
  });
  const uint32_t ticks = 120;
  const uint64_t shared_before = scene.st().stats().fanout_shared;
  for (uint32_t k = 1; k <= ticks; ++k) scene.tick(k);
  const size_t avatars = scene.ids().size();
  for (size_t i = 0; i < scene.subscribers().size(); ++i) {
    const Client& c = *scene.subscribers()[i];
    EXPECT_EQ(c.stats().frames, ticks * avatars) << i;
    EXPECT_EQ(c.stats().lost, 0u) << i;
    EXPECT_EQ(c.stats().out_of_order, 0u) << i;
    EXPECT_EQ(c.stats().lean_unreferenced, 0u) << i;
    if (i % 3 == 0) {
      EXPECT_EQ(c.stats().udp_frames, ticks * avatars) << i;
    }
    for (const auto& [id, a] : c.avatars()) EXPECT_EQ(a.last.sequence, ticks) << i;
  }
  const auto stats = scene.st().stats();
  EXPECT_EQ(stats.fanout_shared - shared_before, ticks);  // every tick went out on several threads
  EXPECT_EQ(stats.frames_dropped, 0u);
  EXPECT_GE(stats.frames_out, uint64_t(ticks) * avatars * scene.subscribers().size());
  EXPECT_GT(stats.lean_deltas_out, stats.lean_keys_out);
}

// A subscriber that stops reading, written by a worker thread: the kernel takes part of a tick's
// write, the server's thread finishes it asynchronously, latest wins for that subscriber alone,
// and what it finally reads is a whole stream ending with the newest frame.
TEST(ParallelFanout, StalledSubscriberOnAWorkerLosesOnlyItsOwnFrames) {
  ServerOptions opt = shared_fanout();
  opt.send_buffer_bytes = 4096;
  Scene scene(opt);
  ServerThread& st = scene.st();
  scene.add_avatars(4);
  scene.join(4);
  // Joins last: the last share of the subscribers, a worker's.
  RawPeer stalled(st.port(), 2048);
  ASSERT_TRUE(stalled.send(hello_packet(Role::subscriber)));  // ... and never reads until the end
  ASSERT_TRUE(pump(scene.subscribers(), [&] { return st.stats().subscribers == 5; }));
  const uint32_t ticks = 300;
  for (uint32_t k = 1; k <= ticks; ++k) scene.tick(k);
  for (auto* c : scene.subscribers()) {
    EXPECT_EQ(c->stats().frames, ticks * scene.ids().size());
    EXPECT_EQ(c->stats().lost, 0u);
  }
  uint64_t stalled_dropped = 0;
  for (const auto& s : st.sessions())
    if (s.role == Role::subscriber && s.name == "raw") stalled_dropped = s.frames_dropped;
  EXPECT_GT(stalled_dropped, 0u);
  EXPECT_EQ(st.stats().frames_dropped, stalled_dropped);
  PacketReader r;
  feed(r, stalled.read_until_quiet(0.3));
  std::vector<uint32_t> last(scene.ids().back() + 1u, 0);
  uint64_t frames = 0;
  for (;;) {
    std::span<const uint8_t> p;
    ASSERT_EQ(r.next(p), Reject::ok);  // whole packets only: nothing torn between threads
    if (p.empty()) break;
    if (p[2] != uint8_t(MsgType::pose)) continue;
    const uint16_t a = pose_avatar(p);
    ASSERT_LT(a, last.size());
    EXPECT_GT(pose_sequence(p), last[a]);  // in order
    last[a] = pose_sequence(p);
    frames++;
  }
  for (uint16_t id : scene.ids()) EXPECT_EQ(last[id], ticks) << id;
  EXPECT_LT(frames, uint64_t(ticks) * scene.ids().size());
}

// The fan-out threads' scheduling policies, by their name.
std::vector<int> fanout_thread_policies() {
  std::vector<int> v;
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream f(e.path() / "comm");
    std::string name;
    std::getline(f, name);
    if (name == "mimic-fanout") v.push_back(sched_getscheduler(pid_t(std::stol(e.path().filename().string()))));
  }
  return v;
}

// The workers take the publishing thread's policy as the kernel has it, even when it was set
// from outside (chrt -p, or sched_setscheduler on the thread id) after glibc cached another
// answer for pthread_getschedparam. SCHED_BATCH needs no privilege.
TEST(ParallelFanout, WorkersFollowThePublishingThreadsPolicy) {
  Scene scene(shared_fanout());
  scene.add_avatars(1);
  scene.join(4);
  scene.tick(1);  // starts the workers, at the server thread's policy
  const auto before = fanout_thread_policies();
  ASSERT_EQ(before.size(), 2u);
  for (int p : before) EXPECT_EQ(p, SCHED_OTHER);
  const bool changed = scene.st().call([] {
    int policy = 0;
    sched_param param{};
    pthread_getschedparam(pthread_self(), &policy, &param);  // glibc now caches SCHED_OTHER
    return sched_setscheduler(0, SCHED_BATCH, &param) == 0;
  });
  ASSERT_TRUE(changed);
  scene.tick(2);
  for (int p : fanout_thread_policies()) EXPECT_EQ(p, SCHED_BATCH);
  EXPECT_EQ(scene.st().stats().fanout_shared, 2u);
}

}  // namespace
}  // namespace mimic::net::parallel_fanout_test
