// The loop: Pipeline::tick() (read → solve → encode → send, then deform → mesh frames) over a
// list of pose sinks, on a Clock; the stage timers.
#include "mimic/service/pipeline.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "mimic/core/percentile.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/server.h"  // wall_clock_us

namespace mimic::service {

const char* stage_name(int stage) {
  static const char* kNames[kStageCount] = {"read", "solve", "deform", "encode", "send", "latency"};
  return stage >= 0 && stage < kStageCount ? kNames[stage] : "?";
}

void StageTimer::add(double us) {
  ring_[next_] = static_cast<float>(us);
  next_ = (next_ + 1) % ring_.size();
  filled_ = std::min(filled_ + 1, ring_.size());
  count_++;
}

StageTimer::Summary StageTimer::summary() {
  Summary s;
  s.count = count_;
  if (filled_ == 0) return s;
  std::copy_n(ring_.begin(), filled_, scratch_.begin());
  const std::span<double> window(scratch_.data(), filled_);
  s.p50_us = percentile_in_place(window, 0.50);
  s.p99_us = percentile_in_place(window, 0.99);
  s.max_us = *std::max_element(window.begin(), window.end());
  return s;
}

Pipeline::Pipeline(SinkList sinks, std::shared_ptr<const Clock> clock)
    : sinks_(std::move(sinks)), clock_(clock ? std::move(clock) : std::make_shared<SteadyClock>()) {}

Status Pipeline::add_avatar(const std::string& name, std::unique_ptr<PoseFeed> feed, std::string model_bytes,
                            std::unique_ptr<Deformer> deformer) {
  Avatar a;
  a.name = name;
  const auto& s = feed->skeleton();
  AvatarJoin join{avatars_.size(), a.name, s, model_bytes};
  for (auto& sink : sinks_)
    if (auto st = sink->add_avatar(join); !st) return st;
  a.wire_id = join.wire_id;
  if (auto st = feed->start(); !st) return st;
  a.pose = s.rest_pose();
  a.packet.resize(net::pose_packet_bytes(s.dof_count()));
  a.feed = std::move(feed);
  a.deformer = deformer ? std::move(deformer) : make_fk_deformer(s);
  // The mesh topology is fixed: announce it (and size the frame buffer) now, not when the first
  // thin client (or a relay asking through the broker) shows up in the middle of the loop.
  a.deformer->deform(a.pose);
  if (!sinks_.empty() && a.deformer->mesh()) {
    const avatar::Mesh& mesh = *a.deformer->mesh();
    net::MeshTopology t;
    t.avatar = a.wire_id;
    t.lod = a.deformer->lod();
    t.vertex_count = static_cast<uint32_t>(mesh.positions.size());
    t.indices = mesh.indices;
    if (const avatar::TextureLayout* tex = a.deformer->texture()) {
      t.uv_source = tex->source;
      t.uvs = tex->uv;
      t.uv_indices = tex->indices;
    }
    a.mesh_packet.resize(net::mesh_packet_bytes(mesh.positions.size()));
    const size_t n = net::encode_mesh({a.wire_id, t.lod, 0, 0}, mesh.positions, a.mesh_packet);
    for (auto& sink : sinks_)
      if (auto st = sink->add_mesh(avatars_.size(), t, std::span<const uint8_t>(a.mesh_packet.data(), n)); !st)
        return st;
  }
  avatars_.push_back(std::move(a));
  pending_latency_.assign(avatars_.size(), 0.0);
  pending_send_us_.assign(avatars_.size(), 0.0);
  return {};
}

Status Pipeline::service_network(int idle_us) {
  for (auto& sink : sinks_)
    if (auto st = sink->poll(); !st) return st;
  if (idle_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(idle_us));
  return {};
}

// Mesh frames only while some sink wants this avatar's LOD: encoded once for all of them. The
// topology was announced at setup (add_avatar), so nothing here allocates.
void Pipeline::send_mesh(size_t index, Avatar& a) {
  const avatar::Mesh& mesh = *a.deformer->mesh();
  const uint8_t lod = a.deformer->lod();
  bool wanted = false;
  for (const auto& sink : sinks_) wanted = wanted || sink->wants_mesh(index, lod);
  if (!wanted) return;
  const size_t n = net::encode_mesh({a.wire_id, lod, a.sequence, a.time_us}, mesh.positions, a.mesh_packet);
  if (n == 0) {
    send_failures_++;
    return;
  }
  const MeshOut out{index, lod, mesh, std::span<const uint8_t>(a.mesh_packet.data(), n)};
  for (auto& sink : sinks_)
    if (sink->wants_mesh(index, lod) && !sink->send_mesh(out)) send_failures_++;
}

void Pipeline::send_pose(size_t index, Avatar& a, const net::PoseHeader& h, size_t bytes, bool stale_repeat) {
  const FrameOut out{index,
                     h,
                     a.pose,
                     std::span<const uint8_t>(a.packet.data(), bytes),
                     a.feed->latest_samples(),
                     double(h.time_us) * 1e-6,
                     stale_repeat};
  for (auto& sink : sinks_) {
    if (stale_repeat && !sink->forwards_stale_repeats()) continue;
    if (!sink->send(out)) send_failures_++;
  }
}

// The source is silent. Once it has been for kStaleRepeat_s, the last pose goes out again
// flagged stale, at that lower rate: subscribers can tell a dead source from a quiet one.
void Pipeline::repeat_stale(size_t index, Avatar& a) {
  const double t = clock_->now_s();
  if (a.sequence == 0 || t - a.last_send_s < kStaleRepeat_s) return;
  if (!a.silent) silent_sources_++;
  a.silent = true;
  a.last_send_s = t;
  net::PoseHeader h;
  h.avatar = a.wire_id;
  h.sequence = ++a.sequence;
  h.flags = net::kPoseStale;
  h.time_us = a.time_us;  // still the capture time of the data it shows
  send_pose(index, a, h, net::encode_pose(h, a.pose, a.packet), true);
  stale_frames_++;
}

void Pipeline::tick() {
  const auto us = [](double a_s, double b_s) { return (b_s - a_s) * 1e6; };
  // Pose frames first: receivers deform locally, so the pose stream does not wait for the skin.
  // Sinks batch them: one write per subscriber for all avatars of this pass, one broker message.
  for (auto& sink : sinks_) sink->begin(PoseSink::Phase::poses);
  for (size_t i = 0; i < avatars_.size(); ++i) {
    Avatar& a = avatars_[i];
    const double t0 = clock_->now_s();
    const size_t n = a.feed->read();
    const double t1 = clock_->now_s();
    timers_[kStageRead].add(us(t0, t1));
    if (n == 0) {
      repeat_stale(i, a);
      continue;
    }
    if (a.silent) silent_sources_--;
    a.silent = false;
    a.last_send_s = t1;
    double capture_s = 0;
    bool stale = false;
    a.feed->solve(a.pose, capture_s, stale);
    const double t2 = clock_->now_s();
    const double age_s = std::max(0.0, t2 - capture_s);
    net::PoseHeader h;
    h.avatar = a.wire_id;
    h.sequence = ++a.sequence;
    h.flags = stale ? net::kPoseStale : 0;
    h.time_us = net::wall_clock_us() - static_cast<uint64_t>(age_s * 1e6);
    a.time_us = h.time_us;
    const size_t bytes = net::encode_pose(h, a.pose, a.packet);
    const double t3 = clock_->now_s();
    send_pose(i, a, h, bytes, false);
    timers_[kStageSolve].add(us(t1, t2));
    timers_[kStageEncode].add(us(t2, t3));
    pending_send_us_[i] = us(t3, clock_->now_s());
    pending_latency_[i] = capture_s;
    frames_++;
  }
  // The pose frames leave the sockets here: every avatar of this pass counts the flush in its
  // send stage, and its latency (sensor record -> frame out) ends here.
  const double flush_start_s = clock_->now_s();
  for (auto& sink : sinks_) sink->end(PoseSink::Phase::poses);
  const double now = clock_->now_s();
  const double flush_us = us(flush_start_s, now);
  // Then the skin, and mesh frames for thin clients (batched the same way).
  for (auto& sink : sinks_) sink->begin(PoseSink::Phase::meshes);
  for (size_t i = 0; i < avatars_.size(); ++i) {
    if (pending_latency_[i] <= 0) continue;
    timers_[kStageSend].add(pending_send_us_[i] + flush_us);
    timers_[kStageLatency].add(std::max(0.0, now - pending_latency_[i]) * 1e6);
    pending_latency_[i] = 0;
    Avatar& a = avatars_[i];
    const double d0 = clock_->now_s();
    a.deformer->deform(a.pose);
    timers_[kStageDeform].add(us(d0, clock_->now_s()));
    if (!sinks_.empty() && a.deformer->mesh()) send_mesh(i, a);
  }
  for (auto& sink : sinks_) sink->end(PoseSink::Phase::meshes);
}

}  // namespace mimic::service
