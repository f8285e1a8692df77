// The network outputs as pose sinks (service/sink.h): each adapts one net/ object to the
// pipeline's calling convention and keeps the per-avatar ids that object gave out.
#include "mimic/service/sink.h"

#include <vector>

#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/nats.h"
#include "mimic/net/server.h"
#include "mimic/net/vmc.h"
#include "mimic/net/vrpn_server.h"

namespace mimic::service {
namespace {

// The scene hosted here: numbers the avatars (their wire ids), fans pose frames out to
// subscribers in one write per pass, mesh frames at the LODs subscribers ask for.
class ServerSink final : public PoseSink {
 public:
  explicit ServerSink(net::Server& server) : server_(server) {}
  const char* name() const noexcept override { return "server"; }
  bool forwards_stale_repeats() const noexcept override { return true; }
  Status add_avatar(AvatarJoin& join) override {
    auto id = server_.add_avatar(join.name, static_cast<uint16_t>(join.skeleton.dof_count()), join.model_bytes);
    if (!id) return tl::unexpected(id.error());
    join.wire_id = *id;
    ids_.push_back(*id);
    return {};
  }
  Status add_mesh(size_t avatar, const net::MeshTopology& topology, std::span<const uint8_t> rest_frame) override {
    if (auto st = server_.set_mesh_topology(topology); !st) return st;
    server_.publish_mesh(ids_[avatar], topology.lod, rest_frame);
    return {};
  }
  void begin(Phase) noexcept override { server_.begin_batch(); }
  bool send(const FrameOut& f) noexcept override {
    return f.packet.empty() || server_.publish_pose(ids_[f.avatar], f.packet) == net::Reject::ok;
  }
  void end(Phase) noexcept override { server_.end_batch(); }
  bool wants_mesh(size_t avatar, uint8_t lod) const noexcept override {
    return lod < 8 && (server_.mesh_lods_wanted(ids_[avatar]) & (1u << lod));
  }
  bool send_mesh(const MeshOut& m) noexcept override {
    return server_.publish_mesh(ids_[m.avatar], m.lod, m.packet) == net::Reject::ok;
  }
  Status poll() override {
    server_.poll();
    return {};
  }

 private:
  net::Server& server_;
  std::vector<uint16_t> ids_;
};

// A scene hosted elsewhere: the client re-encodes from the pose (its own avatar slots).
class PublisherSink final : public PoseSink {
 public:
  explicit PublisherSink(net::Client& client) : client_(client) {}
  const char* name() const noexcept override { return "publisher"; }
  bool forwards_stale_repeats() const noexcept override { return true; }
  Status add_avatar(AvatarJoin& join) override {
    auto slot = client_.add_avatar(join.name, static_cast<uint16_t>(join.skeleton.dof_count()), join.model_bytes);
    if (!slot) return tl::unexpected(slot.error());
    slots_.push_back(*slot);
    return {};
  }
  bool send(const FrameOut& f) noexcept override {
    return static_cast<bool>(client_.publish_pose(slots_[f.avatar], f.header, f.pose));
  }
  Status poll() override { return client_.poll(); }

 private:
  net::Client& client_;
  std::vector<uint8_t> slots_;
};

// A NATS broker: each pass's pose frames in one message; mesh frames while a relay asks.
class NatsSink final : public PoseSink {
 public:
  explicit NatsSink(net::NatsPublisher& nats) : nats_(nats) {}
  const char* name() const noexcept override { return "nats"; }
  bool forwards_stale_repeats() const noexcept override { return true; }
  Status add_avatar(AvatarJoin& join) override {
    auto index = nats_.add_avatar(join.name, static_cast<uint16_t>(join.skeleton.dof_count()), join.model_bytes);
    if (!index) return tl::unexpected(index.error());
    indices_.push_back(*index);
    return {};
  }
  Status add_mesh(size_t avatar, const net::MeshTopology& topology, std::span<const uint8_t>) override {
    return nats_.add_mesh(indices_[avatar], topology);
  }
  // Only the pose frames are batched into one broker message per pass.
  void begin(Phase phase) noexcept override {
    if (phase == Phase::poses) nats_.begin_tick();
  }
  bool send(const FrameOut& f) noexcept override {
    if (!f.packet.empty()) nats_.publish_pose(indices_[f.avatar], f.packet);
    return true;  // the broker's own counters say what it dropped
  }
  void end(Phase phase) noexcept override {
    if (phase == Phase::poses) nats_.end_tick();  // only wakes the sender thread
  }
  bool wants_mesh(size_t avatar, uint8_t) const noexcept override { return nats_.mesh_wanted(indices_[avatar]); }
  bool send_mesh(const MeshOut& m) noexcept override {
    nats_.publish_mesh(indices_[m.avatar], m.packet);
    return true;
  }

 private:
  net::NatsPublisher& nats_;
  std::vector<int> indices_;
};

// VMC (OSC over UDP): avatar i to the sender's avatar i, bones from the pose.
class VmcSink final : public PoseSink {
 public:
  explicit VmcSink(net::VmcSender& vmc) : vmc_(vmc) {}
  const char* name() const noexcept override { return "vmc"; }
  bool forwards_stale_repeats() const noexcept override { return false; }
  Status add_avatar(AvatarJoin& join) override { return vmc_.add_avatar(join.skeleton); }
  bool send(const FrameOut& f) noexcept override { return vmc_.send(f.avatar, f.pose, f.time_s) != 0; }

 private:
  net::VmcSender& vmc_;
};

// VRPN trackers: Avatar<i> (one sensor per joint) and Sensors<i> (the tracker samples).
class VrpnSink final : public PoseSink {
 public:
  explicit VrpnSink(net::VrpnServer& vrpn) : vrpn_(vrpn) {}
  const char* name() const noexcept override { return "vrpn"; }
  bool forwards_stale_repeats() const noexcept override { return false; }
  Status add_avatar(AvatarJoin& join) override { return vrpn_.add_avatar(join.skeleton); }
  bool send(const FrameOut& f) noexcept override {
    vrpn_.send_pose(f.avatar, f.pose, f.time_s);
    for (const auto& s : f.samples) vrpn_.send_sample(f.avatar, s.sensor, s.position_m, s.orientation, f.time_s);
    vrpn_.flush();
    return true;
  }
  Status poll() override {
    vrpn_.poll();
    return {};
  }

 private:
  net::VrpnServer& vrpn_;
};

}  // namespace

std::unique_ptr<PoseSink> make_server_sink(net::Server& server) { return std::make_unique<ServerSink>(server); }
std::unique_ptr<PoseSink> make_publisher_sink(net::Client& publisher) {
  return std::make_unique<PublisherSink>(publisher);
}
std::unique_ptr<PoseSink> make_nats_sink(net::NatsPublisher& nats) { return std::make_unique<NatsSink>(nats); }
std::unique_ptr<PoseSink> make_vmc_sink(net::VmcSender& vmc) { return std::make_unique<VmcSink>(vmc); }
std::unique_ptr<PoseSink> make_vrpn_sink(net::VrpnServer& vrpn) { return std::make_unique<VrpnSink>(vrpn); }

}  // namespace mimic::service
