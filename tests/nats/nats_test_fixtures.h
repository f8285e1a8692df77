// Fixtures of the broker tests (nats_test.cpp, nats_trust_test.cpp): a publisher thread as
// `mimic run --nats` drives one, a relay as `mimic relay` runs one, viewers, and the options of
// a test broker's users.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <future>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "mimic/net/nats.h"
#include "nats_broker.h"
#include "../net/net_test_support.h"

namespace mimic::net {
// Internal to each test file that includes it (the helpers below may go unused in one).
namespace {

using ::mimic::test::NatsBroker;
using ::mimic::test::NatsCluster;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

constexpr uint16_t kDofs = 12;

#define REQUIRE_NATS()                                                                                        \
  do {                                                                                                        \
    ASSERT_FALSE(::mimic::test::nats_server_binary().empty()) << "nats-server missing: run scripts/setup.sh"; \
  } while (0)

// Publishes `avatars` avatars at `hz` from a thread, as mimic run --nats does: encoded pose
// frames stamped with the wall clock at publish time, a tick of them at a time.
// A square of two triangles whose corners move with the sequence number: the mesh of an
// avatar deformed at `lod` (mesh_lod < 0: none), sent as the pipeline sends it, only while
// mesh_wanted() says a relay asks.
[[maybe_unused]] MeshTopology test_topology(uint8_t lod) {
  MeshTopology t;
  t.lod = lod;
  t.vertex_count = 4;
  t.indices = {0, 1, 2, 0, 2, 3};
  return t;
}
[[maybe_unused]] std::vector<glm::vec3> test_positions(uint32_t sequence) {
  const float x = float(sequence % 100) * 0.01f;
  return {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
}

class TestPublisher {
 public:
  TestPublisher(const NatsOptions& o, int avatars, double hz = 90, int mesh_lod = -1) {
    auto p = NatsPublisher::create(o);
    if (!p) throw std::runtime_error(p.error().what());
    pub_ = std::move(*p);
    for (int i = 0; i < avatars; ++i) {
      auto idx =
          pub_->add_avatar("avatar" + std::to_string(i + 1), kDofs, "model of " + o.name + " " + std::to_string(i));
      if (!idx) throw std::runtime_error(idx.error().what());
      if (mesh_lod >= 0)
        if (auto st = pub_->add_mesh(*idx, test_topology(uint8_t(mesh_lod))); !st)
          throw std::runtime_error(st.error().what());
    }
    thread_ = std::thread([this, avatars, hz, mesh_lod] {
      rig::Pose pose;
      pose.dof_rad.assign(kDofs, 0.1f);
      std::vector<uint8_t> buf(pose_packet_bytes(kDofs)), mesh(mesh_packet_bytes(4));
      std::vector<uint32_t> seq(size_t(avatars), 0);
      auto next = Clock::now();
      while (!stop_) {
        if (paused_) {
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
          next = Clock::now();
          continue;
        }
        pub_->begin_tick();
        for (int i = 0; i < avatars; ++i) {
          PoseHeader h;
          h.avatar = uint16_t(i);
          h.sequence = ++seq[size_t(i)];
          h.time_us = wall_clock_us();
          pose.root_position_m.x = float(h.sequence) * 1e-3f;
          const size_t n = encode_pose(h, pose, buf);
          pub_->publish_pose(i, std::span<const uint8_t>(buf.data(), n));
          if (mesh_lod >= 0 && pub_->mesh_wanted(i)) {
            const size_t m =
                encode_mesh({0, uint8_t(mesh_lod), h.sequence, h.time_us}, test_positions(h.sequence), mesh);
            pub_->publish_mesh(i, std::span<const uint8_t>(mesh.data(), m));
            mesh_sent_++;
          }
        }
        pub_->end_tick();
        ticks_++;
        next += std::chrono::microseconds(int64_t(1e6 / hz));
        std::this_thread::sleep_until(next);
      }
    });
  }
  ~TestPublisher() {
    stop_ = true;
    thread_.join();
  }
  NatsPublisher& get() { return *pub_; }
  uint64_t mesh_sent() const { return mesh_sent_; }
  uint64_t ticks() const { return ticks_; }
  // Holds the ticks (the tick under way finishes), so that what was sent can be counted at the far end.
  void pause(bool on) { paused_ = on; }

 private:
  std::unique_ptr<NatsPublisher> pub_;
  std::atomic<uint64_t> mesh_sent_{0}, ticks_{0};
  std::atomic<bool> stop_{false}, paused_{false};
  std::thread thread_;
};

// A relay as mimic relay runs it: a Server on its own thread fed from the broker.
class TestRelay {
 public:
  explicit TestRelay(const NatsOptions& o, uint16_t port = 0) {
    ServerOptions so;
    so.listen = "127.0.0.1:" + std::to_string(port);
    auto s = Server::create(so);
    if (!s) throw std::runtime_error(s.error().what());
    server_ = std::move(*s);
    auto f = NatsSceneFeed::create(o, *server_);
    if (!f) throw std::runtime_error(f.error().what());
    feed_ = std::move(*f);
    thread_ = std::thread([this] { server_->run(); });
  }
  ~TestRelay() {
    server_->stop();
    thread_.join();
    feed_.reset();  // while the server it feeds is not running
  }
  std::string endpoint() const { return server_->endpoint(); }
  uint16_t port() const { return server_->port(); }
  // Fan-outs to the relay's viewers so far (asked on the server's own thread).
  uint64_t fanouts() {
    std::promise<uint64_t> p;
    server_->dispatch([&] { p.set_value(server_->fanout_times().count); });
    return p.get_future().get();
  }
  NatsSceneFeed& feed() { return *feed_; }

 private:
  std::unique_ptr<Server> server_;
  std::unique_ptr<NatsSceneFeed> feed_;
  std::thread thread_;
};

[[maybe_unused]] std::unique_ptr<Client> viewer(const std::string& endpoint, uint8_t mesh_lod = kNoMesh) {
  ClientOptions o;
  o.connect = endpoint;
  o.name = "viewer";
  o.mesh_lod = mesh_lod;
  auto c = Client::connect(o);
  if (!c) throw std::runtime_error(c.error().what());
  return std::move(*c);
}

[[maybe_unused]] NatsOptions options(const std::string& servers, const std::string& name,
                                     const std::string& scene = "lobby") {
  NatsOptions o;
  o.servers = servers;
  o.name = name;
  o.scene = scene;
  return o;
}

[[maybe_unused]] bool sees_all(const Client& c, size_t avatars, uint64_t frames_each = 1) {
  if (c.avatars().size() != avatars) return false;
  for (const auto& [id, a] : c.avatars())
    if (a.frames < frames_each) return false;
  return true;
}

[[maybe_unused]] double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))];
}

}  // namespace
}  // namespace mimic::net
