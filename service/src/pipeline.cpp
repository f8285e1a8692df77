#include "mimic/service/pipeline.h"

#include "feed_on_clock.h"
#include "vmc_feed.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>
#include <cmath>

#include "mimic/avatar/body_presets.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/core/file.h"
#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/nats.h"
#include "mimic/net/server.h"
#include "mimic/net/vmc.h"
#include "mimic/net/vrpn_server.h"
#include "mimic/sim/log.h"
#include "mimic/sim/open_source.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/filters.h"
#include "mimic/solver/model_refiner.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

class MotionFeed final : public PoseFeed {
 public:
  MotionFeed(std::shared_ptr<const rig::Motion> motion, std::unique_ptr<devices::SensorSource> source,
             std::string description)
      : motion_(std::move(motion)), source_(std::move(source)), description_(std::move(description)) {}
  const rig::Skeleton& skeleton() const override { return motion_->skeleton(); }
  std::string describe() const override { return description_; }
  Status start() override { return source_->start(); }
  size_t read() override {
    size_t total = 0;
    for (;;) {
      const size_t n = source_->poll(samples_);
      for (size_t i = 0; i < n; ++i) {
        const auto& s = samples_[i];
        newest_host_s_ = std::max(newest_host_s_, s.host_time_s);
        newest_device_s_ = std::max(newest_device_s_, s.device_time_s);
        stale_ = (s.flags & devices::kSampleValid) == 0;
      }
      total += n;
      if (n < samples_.size()) break;
    }
    return total;
  }
  void solve(rig::Pose& pose, double& capture_s, bool& stale) override {
    // Stand-in for the solver: the true pose of the virtual body at the newest sample.
    motion_->sample(newest_device_s_, pose);
    capture_s = newest_host_s_;
    stale = stale_;
  }
  devices::DeviceStatus status() const override { return source_->status(); }

 private:
  std::shared_ptr<const rig::Motion> motion_;
  std::unique_ptr<devices::SensorSource> source_;
  std::string description_;
  std::array<devices::SensorSample, 64> samples_{};
  double newest_host_s_ = 0, newest_device_s_ = 0;
  bool stale_ = false;
};

// Tracker samples through the body solver: the newest sample of every sensor is kept, and the
// solve stage runs the solver warm-started from the previous frame.
class SolverFeed final : public PoseFeed {
 public:
  // With a calibration, the model is refined from the stream as the wearer moves (functional
  // calibration, solver/model_refiner.h): limb lengths in place, joint centres by a new model
  // built on a worker thread and swapped in between frames.
  SolverFeed(solver::SolverModel model, std::unique_ptr<devices::SensorSource> source, std::string description,
             const solver::Calibration* calibration = nullptr)
      : model_(std::make_unique<solver::SolverModel>(std::move(model))),
        context_(std::make_unique<solver::SolverContext>(*model_)),
        filters_(static_cast<int>(kMaxSensors) - 1),
        source_(std::move(source)),
        description_(std::move(description)) {
    latest_.resize(kMaxSensors);
    have_.assign(kMaxSensors, 0);
    fresh_.assign(kMaxSensors, 0);
    packed_.reserve(kMaxSensors);
    warm_ = model_->skeleton().rest_pose();
    if (calibration) {
      refine_ = std::make_unique<Refinement>(solver::ModelRefiner(*calibration, *model_, 120.0));
      refine_->thread = std::thread([r = refine_.get()] { r->run(); });
    }
  }
  ~SolverFeed() override {
    if (!refine_) return;
    {
      std::lock_guard lock(refine_->mutex);
      refine_->stop = true;
    }
    refine_->cv.notify_one();
    refine_->thread.join();
  }
  const rig::Skeleton& skeleton() const override { return model_->skeleton(); }
  std::string describe() const override { return description_; }
  Status start() override { return source_->start(); }
  size_t read() override {
    size_t total = 0;
    for (;;) {
      const size_t n = source_->poll(samples_);
      // The refinement sees the raw samples (never waiting: a busy worker costs it a tick).
      if (refine_ && n > 0 && refine_->mutex.try_lock()) {
        const bool due = refine_->refiner.add(std::span<const devices::SensorSample>(samples_.data(), n), *model_);
        refine_->due = refine_->due || due;
        refine_->mutex.unlock();
        if (due) refine_->cv.notify_one();
      }
      // Jitter and outliers out, dropouts bridged, before the solver sees anything.
      filters_.process(std::span<devices::SensorSample>(samples_.data(), n));
      for (size_t i = 0; i < n; ++i) {
        const auto& smp = samples_[i];
        newest_host_s_ = std::max(newest_host_s_, smp.host_time_s);
        if (smp.sensor >= kMaxSensors) continue;
        latest_[smp.sensor] = smp;
        have_[smp.sensor] = 1;
        if (!fresh_[smp.sensor]) {
          fresh_[smp.sensor] = 1;
          if (first_fresh_s_ < 0) first_fresh_s_ = smp.host_time_s;
        }
      }
      total += n;
      if (n < samples_.size()) break;
    }
    // One pose per measurement cycle, not per sensor record: a tracker in group mode (a Flock's
    // birds) delivers a cycle's records one by one, and solving after each would send the same
    // cycle several times over. Solve when every sensor seen so far has a new sample, or when
    // the first new one has waited long enough that a sensor must be missing.
    unsolved_ += total;
    if (unsolved_ == 0) return 0;
    bool cycle_complete = true;
    for (size_t i = 0; i < kMaxSensors; ++i)
      if (have_[i] && !fresh_[i]) cycle_complete = false;
    if (!cycle_complete && newest_host_s_ - first_fresh_s_ < kCycleWait_s) return 0;
    std::fill(fresh_.begin(), fresh_.end(), uint8_t{0});
    first_fresh_s_ = -1;
    const size_t ready = unsolved_;
    unsolved_ = 0;
    return ready;
  }
  std::span<const devices::SensorSample> latest_samples() const override { return packed_; }
  void solve(rig::Pose& pose, double& capture_s, bool& stale) override {
    packed_.clear();  // capacity kept: no allocation
    stale = false;
    for (size_t i = 0; i < kMaxSensors; ++i) {
      if (!have_[i]) continue;
      packed_.push_back(latest_[i]);
      if ((latest_[i].flags & devices::kSampleValid) == 0) stale = true;
    }
    if (refine_ && refine_->mutex.try_lock()) {  // a refined model waiting: swap it in
      const bool swapped = refine_->ready_model != nullptr && !refine_->retired;
      if (swapped) {
        std::swap(model_, refine_->ready_model);  // the old one goes back for the worker to free
        std::swap(context_, refine_->ready_context);
        refine_->retired = true;
      }
      refine_->mutex.unlock();
      if (swapped) refine_->cv.notify_one();
    }
    solver::SolveJob job;
    job.model = model_.get();
    job.samples = packed_;
    job.context = context_.get();
    job.pose = &warm_;
    if (!job.Run()) stale = true;
    // Copy into the caller's pose without reallocating (same DOF count).
    pose.root_position_m = warm_.root_position_m;
    pose.root_orientation = warm_.root_orientation;
    std::copy(warm_.dof_rad.begin(), warm_.dof_rad.end(), pose.dof_rad.begin());
    capture_s = newest_host_s_;
  }
  devices::DeviceStatus status() const override { return source_->status(); }

 private:
  static constexpr size_t kMaxSensors = 64;
  static constexpr double kCycleWait_s = 0.025;  // longer than any tracker's cycle (Flock: ~10 ms)
  struct Refinement {
    explicit Refinement(solver::ModelRefiner r) : refiner(std::move(r)) {}
    solver::ModelRefiner refiner;
    std::mutex mutex;  // guards everything below
    std::condition_variable cv;
    bool due = false, retired = false, stop = false;
    std::unique_ptr<solver::SolverModel> ready_model;  // built, waiting to be swapped in; after a
    std::unique_ptr<solver::SolverContext> ready_context;  // swap (retired), the old pair to free
    std::thread thread;
    void run() {
      std::unique_lock lock(mutex);
      for (;;) {
        cv.wait(lock, [&] { return stop || due || retired; });
        if (stop) return;
        if (retired) {
          retired = false;
          ready_model.reset();
          ready_context.reset();
        }
        if (!due || ready_model) continue;
        due = false;
        auto next = refiner.rebuild();
        if (!next) continue;
        ready_context = std::make_unique<solver::SolverContext>(**next);
        ready_model = std::move(*next);
        std::fprintf(stderr, "\nmimic: calibration refined from the motion: %d joint centres, %d limb lengths\n",
                     refiner.refined_joints(), refiner.refined_limbs());
      }
    }
  };
  std::unique_ptr<solver::SolverModel> model_;
  std::unique_ptr<solver::SolverContext> context_;
  std::unique_ptr<Refinement> refine_;
  solver::SensorFilterBank filters_;
  std::unique_ptr<devices::SensorSource> source_;
  std::string description_;
  std::array<devices::SensorSample, 64> samples_{};
  std::vector<devices::SensorSample> latest_, packed_;
  std::vector<uint8_t> have_;
  std::vector<uint8_t> fresh_;  // a sample arrived since the last solve
  double first_fresh_s_ = -1;   // host time of the first of those
  size_t unsolved_ = 0;         // samples read since the last solve
  rig::Pose warm_;
  double newest_host_s_ = 0;
};

class FkDeformer final : public Deformer {
 public:
  explicit FkDeformer(const rig::Skeleton& s) : skeleton_(s), frames_(size_t(s.joint_count())) {}
  void deform(const rig::Pose& pose) override { rig::forward_kinematics(skeleton_, pose, frames_); }

 private:
  rig::Skeleton skeleton_;
  std::vector<rig::RigidTransform> frames_;
};

}  // namespace

Status service_network(const PipelineOutputs& out, int idle_us) {
  if (out.server) out.server->poll();
  if (out.vrpn) out.vrpn->poll();
  if (out.publisher)
    if (auto st = out.publisher->poll(); !st) return st;
  if (idle_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(idle_us));
  return {};
}

bool set_realtime_priority(int priority) {
  sched_param p{};
  p.sched_priority = priority;
  return pthread_setschedparam(pthread_self(), priority > 0 ? SCHED_FIFO : SCHED_OTHER, &p) == 0;
}

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
  auto end = scratch_.begin() + static_cast<long>(filled_);
  auto at = [&](double q) {
    auto it = scratch_.begin() + static_cast<long>(std::min<double>(double(filled_ - 1), q * double(filled_ - 1) + 0.5));
    std::nth_element(scratch_.begin(), it, end);
    return double(*it);
  };
  s.p50_us = at(0.50);
  s.p99_us = at(0.99);
  s.max_us = double(*std::max_element(scratch_.begin(), end));
  return s;
}

Result<std::shared_ptr<const rig::Motion>> builtin_motion(const std::string& name,
                                                             const rig::Skeleton& skeleton) {
  auto m = rig::make_builtin_motion(name, skeleton);
  if (!m) return tl::unexpected(m.error());
  return std::shared_ptr<const rig::Motion>(std::move(*m));
}

Result<std::unique_ptr<PoseFeed>> make_motion_feed(std::shared_ptr<const rig::Motion> motion,
                                                   std::unique_ptr<devices::SensorSource> source,
                                                   std::string description) {
  return std::unique_ptr<PoseFeed>(new MotionFeed(std::move(motion), std::move(source), std::move(description)));
}

namespace {

// The mounts a log recorded with its sensors (a simulated rig writes its exact ones), when every
// sensor names a segment of `skeleton`; otherwise none, and the standard layout is assumed.
std::optional<std::vector<solver::SensorMount>> recorded_mounts(const std::string& log_path,
                                                                const rig::Skeleton& skeleton) {
  auto log = sim::read_log(log_path);
  if (!log || log->header.sensors.empty()) return std::nullopt;
  std::vector<solver::SensorMount> mounts;
  for (const sim::LogSensor& s : log->header.sensors) {
    if (s.segment.empty() || skeleton.find_joint(s.segment) < 0) return std::nullopt;
    mounts.push_back({s.id, s.segment, s.segment_from_sensor});
  }
  return mounts;
}

}  // namespace

Result<std::unique_ptr<PoseFeed>> open_feed(const std::string& spec_text, const std::string& calibration_path,
                                            const rig::Skeleton* body) {
  return open_feed_on_clock(spec_text, calibration_path, body, nullptr);
}

Result<std::unique_ptr<PoseFeed>> open_feed_on_clock(const std::string& spec_text, const std::string& calibration_path,
                                                     const rig::Skeleton* body,
                                                     std::shared_ptr<const Clock> clock) {
  auto spec = devices::parse_source_spec(spec_text);
  if (!spec) return tl::unexpected(spec.error());
  if (spec->scheme == "vmc") return open_vmc_feed(*spec, body);  // poses, not tracker samples
  if (!calibration_path.empty()) {
    auto cal = solver::load_calibration(calibration_path);
    if (!cal) return tl::unexpected(cal.error());
    auto model = solver::make_solver_model(*cal);
    if (!model) return tl::unexpected(model.error());
    auto source = sim::open_sensor_source(*spec, clock);
    if (!source) return tl::unexpected(source.error());
    std::string desc = (*source)->status().description;
    if (desc.empty()) desc = spec_text;
    return std::unique_ptr<PoseFeed>(
        new SolverFeed(std::move(*model), std::move(*source), desc + ", calibration " + calibration_path, &*cal));
  }
  auto skeleton = body ? Result<rig::Skeleton>(*body) : rig::Skeleton::build(rig::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  // Where the sensors sit: a simulated rig knows exactly; a real tracker uses the standard
  // layout's instructed placements until a calibration is given.
  std::vector<solver::SensorMount> mounts;
  std::optional<std::vector<solver::SensorMount>> recorded;
  if (spec->scheme == "replay" && spec->params.find("sensors") == spec->params.end())
    recorded = recorded_mounts(spec->target, *skeleton);
  if (spec->scheme == "sim" || spec->scheme == "bvh") {
    auto rig = sim::rig_config_from_spec(*spec, *skeleton);
    if (!rig) return tl::unexpected(rig.error());
    for (size_t i = 0; i < rig->sensors.size(); ++i)
      mounts.push_back({static_cast<uint16_t>(i), rig->sensors[i].segment, rig->sensors[i].segment_from_sensor});
  } else if (recorded) {
    mounts = std::move(*recorded);
  } else {
    auto it = spec->params.find("sensors");
    auto layout = solver::standard_layout(it == spec->params.end() ? "6" : it->second, *skeleton);
    if (!layout) return tl::unexpected(layout.error());
    for (const auto& b : layout->bindings) {
      rig::RigidTransform t;
      t.translation = b.placement_m;
      mounts.push_back({b.sensor, b.segment, t});
    }
  }
  // A simulated wearer stands as tall as the skeleton it wears: its legs can step when untracked.
  solver::SolverOptions options;
  if (spec->scheme == "sim" || spec->scheme == "bvh") options.standing_root_y_m = rig::standing_root_height_m(*skeleton);
  auto model = solver::SolverModel::create(*skeleton, std::move(mounts), options);
  if (!model) return tl::unexpected(model.error());
  auto source = sim::open_sensor_source(*spec, std::move(clock), nullptr, body);
  if (!source) return tl::unexpected(source.error());
  std::string desc = (*source)->status().description;
  if (desc.empty()) desc = spec_text;
  return std::unique_ptr<PoseFeed>(new SolverFeed(std::move(*model), std::move(*source), desc));
}

std::unique_ptr<Deformer> make_fk_deformer(const rig::Skeleton& skeleton) {
  return std::make_unique<FkDeformer>(skeleton);
}

Result<BodyAsset> load_body(const std::string& path) {
  BodyAsset body;
  if (path.empty()) {
    body.model = avatar::default_body_model();
  } else {
    auto m = avatar::load_body_or_preset(path);
    if (!m) return tl::unexpected(m.error());
    body.model = std::move(*m);
  }
  if (auto st = avatar::validate(body.model); !st) return tl::unexpected(st.error());
  body.bytes = avatar::to_json(body.model, false);
  return body;
}

namespace {

class SkinDeformer final : public Deformer {
 public:
  SkinDeformer(avatar::BodySkin skin, uint8_t lod) : skin_(std::move(skin)), lod_(lod) {}
  void deform(const rig::Pose& pose) override { skin_.evaluate(pose); }
  const avatar::Mesh* mesh() const override { return &skin_.mesh(); }
  uint8_t lod() const override { return lod_; }

 private:
  avatar::BodySkin skin_;
  uint8_t lod_;
};

// The realtime method: the contours measured once in the shared body, moved every frame.
class RealtimeDeformer final : public Deformer {
 public:
  explicit RealtimeDeformer(std::shared_ptr<const avatar::RealtimeBody> body)
      : skin_(body), mesh_(body->rest_mesh()), lod_(static_cast<uint8_t>(body->lod())) {
    mesh_.normals.clear();  // receivers that want normals compute them from the fixed topology
  }
  void deform(const rig::Pose& pose) override { skin_.evaluate(pose, mesh_.positions); }
  const avatar::Mesh* mesh() const override { return &mesh_; }
  uint8_t lod() const override { return lod_; }

 private:
  avatar::RealtimeSkin skin_;
  avatar::Mesh mesh_;
  uint8_t lod_;
};

}  // namespace

Result<std::unique_ptr<Deformer>> make_skin_deformer(const avatar::BodyModel& model,
                                                     const rig::Skeleton& skeleton, int lod,
                                                     avatar::SkinMethod method) {
  if (lod < 0 || lod >= kMeshLodCount)
    return fail(Errc::out_of_range, "mesh LOD must be in 0.." + std::to_string(kMeshLodCount - 1));
  if (method == avatar::SkinMethod::realtime) {
    avatar::RealtimeOptions o;
    o.lod = lod;
    auto body = avatar::RealtimeBody::shared(model, skeleton, o);  // avatars of one body share it
    if (!body) return tl::unexpected(body.error());
    return std::unique_ptr<Deformer>(new RealtimeDeformer(*body));
  }
  avatar::SkinOptions o;
  o.subdivision = 0;
  o.normals = false;  // receivers that want normals compute them from the fixed topology
  auto skin = avatar::BodySkin::create(avatar::with_skin_lod(model, lod), skeleton, o);
  if (!skin) return tl::unexpected(skin.error());
  return std::unique_ptr<Deformer>(new SkinDeformer(std::move(*skin), static_cast<uint8_t>(lod)));
}

Status Pipeline::add_avatar(const std::string& name, std::unique_ptr<PoseFeed> feed, std::string model_bytes,
                            std::unique_ptr<Deformer> deformer) {
  Avatar a;
  a.name = name;
  const auto& s = feed->skeleton();
  const auto dofs = static_cast<uint16_t>(s.dof_count());
  if (out_.server) {
    auto id = out_.server->add_avatar(name, dofs, model_bytes);
    if (!id) return tl::unexpected(id.error());
    a.server_id = *id;
  }
  if (out_.publisher) {
    auto slot = out_.publisher->add_avatar(name, dofs, model_bytes);
    if (!slot) return tl::unexpected(slot.error());
    a.publisher_slot = *slot;
  }
  if (out_.nats) {
    auto index = out_.nats->add_avatar(name, dofs, model_bytes);
    if (!index) return tl::unexpected(index.error());
    a.nats_index = *index;
  }
  if (auto st = feed->start(); !st) return st;
  a.pose = s.rest_pose();
  a.packet.resize(net::pose_packet_bytes(s.dof_count()));
  a.feed = std::move(feed);
  a.deformer = deformer ? std::move(deformer) : make_fk_deformer(s);
  // The mesh topology is fixed: announce it (and size the frame buffer) now, not when the first
  // thin client (or a relay asking through the broker) shows up in the middle of the loop.
  a.deformer->deform(a.pose);
  if ((out_.server || out_.nats) && a.deformer->mesh()) {
    const avatar::Mesh& mesh = *a.deformer->mesh();
    net::MeshTopology t;
    t.avatar = a.server_id;
    t.lod = a.deformer->lod();
    t.vertex_count = static_cast<uint32_t>(mesh.positions.size());
    t.indices = mesh.indices;
    a.mesh_packet.resize(net::mesh_packet_bytes(mesh.positions.size()));
    if (out_.nats)
      if (auto st = out_.nats->add_mesh(a.nats_index, t); !st) return st;
    if (out_.server) {
      if (auto st = out_.server->set_mesh_topology(t); !st) return st;
      a.topology_sent = true;
      const size_t n = net::encode_mesh({a.server_id, t.lod, 0, 0}, mesh.positions, a.mesh_packet);
      out_.server->publish_mesh(a.server_id, t.lod, std::span<const uint8_t>(a.mesh_packet.data(), n));
    }
  }
  avatars_.push_back(std::move(a));
  pending_latency_.assign(avatars_.size(), 0.0);
  pending_send_us_.assign(avatars_.size(), 0.0);
  return {};
}

// Mesh frames only while some subscriber (or, through the broker, some relay) wants this LOD:
// encoded once for both. Announcing the topology allocates once (the first time a thin client
// shows up); frames after that reuse the buffer.
void Pipeline::send_mesh(Avatar& a, uint64_t time_us) {
  const avatar::Mesh& mesh = *a.deformer->mesh();
  const uint8_t lod = a.deformer->lod();
  const bool to_server = out_.server && lod < 8 && (out_.server->mesh_lods_wanted(a.server_id) & (1u << lod));
  const bool to_broker = out_.nats && out_.nats->mesh_wanted(a.nats_index);
  if (!to_server && !to_broker) return;
  if (to_server && !a.topology_sent) {
    net::MeshTopology t;
    t.avatar = a.server_id;
    t.lod = lod;
    t.vertex_count = static_cast<uint32_t>(mesh.positions.size());
    t.indices = mesh.indices;
    if (!out_.server->set_mesh_topology(t)) {
      send_failures_++;
      return;
    }
    a.mesh_packet.resize(net::mesh_packet_bytes(mesh.positions.size()));
    a.topology_sent = true;
  }
  const size_t n = net::encode_mesh({a.server_id, lod, a.sequence, time_us}, mesh.positions, a.mesh_packet);
  const std::span<const uint8_t> packet(a.mesh_packet.data(), n);
  if (n == 0 || (to_server && out_.server->publish_mesh(a.server_id, lod, packet) != net::Reject::ok))
    send_failures_++;
  if (n && to_broker) out_.nats->publish_mesh(a.nats_index, packet);
}

void Pipeline::publish_pose_frame(Avatar& a, const net::PoseHeader& h, size_t bytes) {
  const std::span<const uint8_t> packet(a.packet.data(), bytes);
  if (out_.server && bytes && out_.server->publish_pose(a.server_id, packet) != net::Reject::ok) send_failures_++;
  if (out_.publisher && a.publisher_slot >= 0 &&
      !out_.publisher->publish_pose(static_cast<uint8_t>(a.publisher_slot), h, a.pose))
    send_failures_++;
  if (out_.nats && bytes) out_.nats->publish_pose(a.nats_index, packet);
}

void Pipeline::tick() {
  using C = std::chrono::steady_clock;
  auto us = [](C::time_point a, C::time_point b) { return std::chrono::duration<double, std::micro>(b - a).count(); };
  // Pose frames first: receivers deform locally, so the pose stream does not wait for the skin.
  // One write per subscriber for all avatars of this pass, and one broker message.
  if (out_.server) out_.server->begin_batch();
  if (out_.nats) out_.nats->begin_tick();
  for (size_t i = 0; i < avatars_.size(); ++i) {
    Avatar& a = avatars_[i];
    const auto t0 = C::now();
    const size_t n = a.feed->read();
    const auto t1 = C::now();
    timers_[kStageRead].add(us(t0, t1));
    if (n == 0) {
      // The source is silent. Once it has been for a while, the last pose goes out again flagged
      // stale, at a lower rate: subscribers can tell a dead source from a quiet one.
      const double t = now_s();
      if (a.sequence > 0 && t - a.last_send_s >= kStaleRepeat_s) {
        if (!a.silent) silent_sources_++;
        a.silent = true;
        a.last_send_s = t;
        net::PoseHeader h;
        h.avatar = a.server_id;
        h.sequence = ++a.sequence;
        h.flags = net::kPoseStale;
        h.time_us = a.time_us;  // still the capture time of the data it shows
        publish_pose_frame(a, h, net::encode_pose(h, a.pose, a.packet));
        stale_frames_++;
      }
      continue;
    }
    if (a.silent) silent_sources_--;
    a.silent = false;
    a.last_send_s = now_s();
    double capture_s = 0;
    bool stale = false;
    a.feed->solve(a.pose, capture_s, stale);
    const auto t2 = C::now();
    const double age_s = std::max(0.0, now_s() - capture_s);
    net::PoseHeader h;
    h.avatar = a.server_id;
    h.sequence = ++a.sequence;
    h.flags = stale ? net::kPoseStale : 0;
    h.time_us = net::wall_clock_us() - static_cast<uint64_t>(age_s * 1e6);
    a.time_us = h.time_us;
    const size_t bytes = net::encode_pose(h, a.pose, a.packet);
    const auto t3 = C::now();
    publish_pose_frame(a, h, bytes);
    if (out_.vmc && i < out_.vmc->avatar_count() && out_.vmc->send(i, a.pose, double(h.time_us) * 1e-6) == 0)
      send_failures_++;
    if (out_.vrpn && i < out_.vrpn->avatar_count()) {
      const double t_s = double(h.time_us) * 1e-6;
      out_.vrpn->send_pose(i, a.pose, t_s);
      for (const auto& s : a.feed->latest_samples()) out_.vrpn->send_sample(i, s.sensor, s.position_m, s.orientation, t_s);
      out_.vrpn->flush();
    }
    const auto t4 = C::now();
    timers_[kStageSolve].add(us(t1, t2));
    timers_[kStageEncode].add(us(t2, t3));
    pending_send_us_[i] = us(t3, t4);
    pending_latency_[i] = capture_s;
    frames_++;
  }
  // The pose frames leave the sockets here: every avatar of this pass counts the flush in its
  // send stage, and its latency (sensor record -> frame out) ends here.
  double flush_us = 0;
  if (out_.nats) out_.nats->end_tick();  // only wakes the sender: first, so both go out together
  if (out_.server) {
    const auto t0 = C::now();
    out_.server->end_batch();
    flush_us = us(t0, C::now());
  }
  const double now = now_s();
  // Then the skin, and mesh frames for thin clients (batched the same way).
  if (out_.server) out_.server->begin_batch();
  for (size_t i = 0; i < avatars_.size(); ++i) {
    if (pending_latency_[i] <= 0) continue;
    timers_[kStageSend].add(pending_send_us_[i] + flush_us);
    timers_[kStageLatency].add(std::max(0.0, now - pending_latency_[i]) * 1e6);
    pending_latency_[i] = 0;
    Avatar& a = avatars_[i];
    const auto t0 = C::now();
    a.deformer->deform(a.pose);
    timers_[kStageDeform].add(us(t0, C::now()));
    if ((out_.server || out_.nats) && a.deformer->mesh()) send_mesh(a, a.time_us);
  }
  if (out_.server) out_.server->end_batch();
}

}  // namespace mimic::service
