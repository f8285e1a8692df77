// The feeds (read + solve) of the pipeline: tracker samples through the sensor filters and the
// body solver, and the motion-driven stand-in; the spec → feed step for the trackers.
#include "tracker_map.h"
#include "feed_on_clock.h"
#include "vmc_feed.h"

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include "mimic/avatar/body_presets.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/tracker_source.h"
#include "mimic/sim/log.h"
#include "mimic/sim/open_source.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/filters.h"
#include "mimic/solver/model_refiner.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

namespace {

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
  // kCycleWait_s (pipeline.h): longer than any tracker's cycle (Flock: ~10 ms).
  struct Refinement {
    explicit Refinement(solver::ModelRefiner r) : refiner(std::move(r)) {}
    solver::ModelRefiner refiner;
    std::mutex mutex;  // guards everything below
    std::condition_variable cv;
    bool due = false, retired = false, stop = false;
    std::unique_ptr<solver::SolverModel> ready_model;      // built, waiting to be swapped in; after a
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

}  // namespace

Result<std::shared_ptr<const rig::Motion>> builtin_motion(const std::string& name, const rig::Skeleton& skeleton) {
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

// A tracker's sensors where the standard layout `name` places them (its instructed placements).
Result<std::vector<solver::SensorMount>> layout_mounts(const std::string& name, const rig::Skeleton& skeleton) {
  auto layout = solver::standard_layout(name, skeleton);
  if (!layout) return tl::unexpected(layout.error());
  std::vector<solver::SensorMount> mounts;
  for (const auto& b : layout->bindings) {
    rig::RigidTransform t;
    t.translation = b.placement_m;
    mounts.push_back({b.sensor, b.segment, t});
  }
  return mounts;
}

}  // namespace

Result<std::unique_ptr<PoseFeed>> make_tracker_feed(std::unique_ptr<devices::SensorSource> source,
                                                    const rig::Skeleton& skeleton, const std::string& layout,
                                                    std::string description) {
  auto mounts = layout_mounts(layout, skeleton);
  if (!mounts) return tl::unexpected(mounts.error());
  auto model = solver::SolverModel::create(skeleton, std::move(*mounts), {});
  if (!model) return tl::unexpected(model.error());
  return std::unique_ptr<PoseFeed>(new SolverFeed(std::move(*model), std::move(source), std::move(description)));
}

namespace {

Result<std::vector<solver::SensorMount>> network_mounts(const devices::SourceSpec& spec,
                                                        const rig::Skeleton& skeleton) {
  auto layout = network_tracker_layout(spec, skeleton);
  if (!layout) return tl::unexpected(layout.error());
  return mounts_of(*layout);
}

}  // namespace

Result<std::unique_ptr<PoseFeed>> open_feed(const std::string& spec_text, const std::string& calibration_path,
                                            const rig::Skeleton* body) {
  return open_feed_on_clock(spec_text, calibration_path, body, nullptr);
}

Result<std::unique_ptr<PoseFeed>> open_feed_on_clock(const std::string& spec_text, const std::string& calibration_path,
                                                     const rig::Skeleton* body, std::shared_ptr<const Clock> clock) {
  auto spec = devices::parse_source_spec(spec_text);
  if (!spec) return tl::unexpected(spec.error());
  // VMC bones are poses, not tracker samples (VMC devices mapped to segments are samples).
  if (spec->scheme == "vmc" && !is_network_tracker(*spec)) return open_vmc_feed(*spec, body);
  if (!calibration_path.empty()) {
    auto cal = solver::load_calibration(calibration_path);
    if (!cal) return tl::unexpected(cal.error());
    auto model = solver::make_solver_model(*cal);
    if (!model) return tl::unexpected(model.error());
    auto source = open_tracker_source(*spec, clock, nullptr);
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
  } else if (is_network_tracker(*spec)) {
    auto m = network_mounts(*spec, *skeleton);
    if (!m) return tl::unexpected(m.error());
    mounts = std::move(*m);
  } else {
    auto it = spec->params.find("sensors");
    auto layout = layout_mounts(it == spec->params.end() ? "6" : it->second, *skeleton);
    if (!layout) return tl::unexpected(layout.error());
    mounts = std::move(*layout);
  }
  // A simulated wearer stands as tall as the skeleton it wears: its legs can step when untracked.
  solver::SolverOptions options;
  if (spec->scheme == "sim" || spec->scheme == "bvh")
    options.standing_root_y_m = rig::standing_root_height_m(*skeleton);
  auto model = solver::SolverModel::create(*skeleton, std::move(mounts), options);
  if (!model) return tl::unexpected(model.error());
  auto source = open_tracker_source(*spec, std::move(clock), nullptr, body);
  if (!source) return tl::unexpected(source.error());
  std::string desc = (*source)->status().description;
  if (desc.empty()) desc = spec_text;
  return std::unique_ptr<PoseFeed>(new SolverFeed(std::move(*model), std::move(*source), desc));
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

}  // namespace mimic::service
