#include "pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "mimic/core/file.h"
#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/server.h"
#include "mimic/net/vmc.h"
#include "mimic/sim/clock.h"
#include "mimic/sim/sensor_rig.h"
#include "mimic/sim/sim_source.h"

namespace mimic::app {

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// A procedural walk in place (treadmill): legs and arms swing in opposition, the pelvis bobs.
// Stands in for the built-in motions until they are linked into this program.
class StandinWalk final : public avatar::Motion {
 public:
  StandinWalk(const avatar::Skeleton& s, bool idle) : skeleton_(s), idle_(idle) {
    auto find = [&](const char* n) { return s.find_dof(n); };
    l_hip_ = find("l_hip_flexion");
    r_hip_ = find("r_hip_flexion");
    l_knee_ = find("l_knee_flexion");
    r_knee_ = find("r_knee_flexion");
    l_sh_flex_ = find("l_shoulder_flexion");
    r_sh_flex_ = find("r_shoulder_flexion");
    l_sh_abd_ = find("l_shoulder_abduction");
    r_sh_abd_ = find("r_shoulder_abduction");
    l_elbow_ = find("l_elbow_flexion");
    r_elbow_ = find("r_elbow_flexion");
    twist_ = find("spine_mid_twist");
    height_m_ = avatar::standing_root_height_m(s);
  }
  const avatar::Skeleton& skeleton() const override { return skeleton_; }
  double duration_s() const override { return idle_ ? 4.0 : 1.1; }
  bool loops() const override { return true; }
  std::string name() const override { return idle_ ? "idle" : "walk"; }
  void sample(double t_s, avatar::Pose& out) const override {
    constexpr float kPi = 3.14159265f, kDeg = kPi / 180.0f;
    const float ph = float(2.0 * 3.14159265358979 * std::fmod(t_s, duration_s()) / duration_s());
    const float amp = idle_ ? 0.1f : 1.0f;
    out.dof_rad.resize(static_cast<size_t>(skeleton_.dof_count()));
    std::fill(out.dof_rad.begin(), out.dof_rad.end(), 0.0f);
    auto set = [&](int dof, float v) {
      if (dof >= 0) out.dof_rad[static_cast<size_t>(dof)] = v;
    };
    set(l_hip_, amp * 25 * kDeg * std::sin(ph));
    set(r_hip_, -amp * 25 * kDeg * std::sin(ph));
    set(l_knee_, amp * 30 * kDeg * (1 - std::cos(ph)) * 0.5f + amp * 20 * kDeg * std::max(0.0f, -std::sin(ph)));
    set(r_knee_, amp * 30 * kDeg * (1 + std::cos(ph)) * 0.5f + amp * 20 * kDeg * std::max(0.0f, std::sin(ph)));
    set(l_sh_abd_, -75 * kDeg);
    set(r_sh_abd_, -75 * kDeg);
    set(l_sh_flex_, -amp * 20 * kDeg * std::sin(ph));
    set(r_sh_flex_, amp * 20 * kDeg * std::sin(ph));
    set(l_elbow_, 15 * kDeg);
    set(r_elbow_, 15 * kDeg);
    set(twist_, amp * 5 * kDeg * std::sin(ph));
    out.root_position_m = {0.0f, height_m_ - 0.02f * amp * (1 - std::cos(2 * ph)) * 0.5f, 0.0f};
    out.root_orientation = glm::quat(1, 0, 0, 0);
  }

 private:
  avatar::Skeleton skeleton_;
  bool idle_;
  int l_hip_, r_hip_, l_knee_, r_knee_, l_sh_flex_, r_sh_flex_, l_sh_abd_, r_sh_abd_, l_elbow_, r_elbow_, twist_;
  float height_m_ = 0.9f;
};

class MotionFeed final : public PoseFeed {
 public:
  MotionFeed(std::shared_ptr<const avatar::Motion> motion, std::unique_ptr<devices::SensorSource> source,
             std::string description)
      : motion_(std::move(motion)), source_(std::move(source)), description_(std::move(description)) {}
  const avatar::Skeleton& skeleton() const override { return motion_->skeleton(); }
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
  void solve(avatar::Pose& pose, double& capture_s, bool& stale) override {
    // Stand-in for the solver: the true pose of the virtual body at the newest sample.
    motion_->sample(newest_device_s_, pose);
    capture_s = newest_host_s_;
    stale = stale_;
  }
  devices::DeviceStatus status() const override { return source_->status(); }

 private:
  std::shared_ptr<const avatar::Motion> motion_;
  std::unique_ptr<devices::SensorSource> source_;
  std::string description_;
  std::array<devices::SensorSample, 64> samples_{};
  double newest_host_s_ = 0, newest_device_s_ = 0;
  bool stale_ = false;
};

class FkDeformer final : public Deformer {
 public:
  explicit FkDeformer(const avatar::Skeleton& s) : skeleton_(s), frames_(size_t(s.joint_count())) {}
  void deform(const avatar::Pose& pose) override { avatar::forward_kinematics(skeleton_, pose, frames_); }

 private:
  avatar::Skeleton skeleton_;
  std::vector<avatar::RigidTransform> frames_;
};

}  // namespace

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

Result<std::shared_ptr<const avatar::Motion>> builtin_motion(const std::string& name,
                                                             const avatar::Skeleton& skeleton) {
  if (name == "walk" || name == "idle") return std::make_shared<StandinWalk>(skeleton, name == "idle");
  return fail(Errc::not_found, "unknown built-in motion '" + name + "' (known: walk, idle)");
}

Result<std::unique_ptr<PoseFeed>> make_motion_feed(std::shared_ptr<const avatar::Motion> motion,
                                                   std::unique_ptr<devices::SensorSource> source,
                                                   std::string description) {
  return std::unique_ptr<PoseFeed>(new MotionFeed(std::move(motion), std::move(source), std::move(description)));
}

Result<std::unique_ptr<PoseFeed>> open_feed(const std::string& spec_text) {
  auto spec = devices::parse_source_spec(spec_text);
  if (!spec) return tl::unexpected(spec.error());
  if (spec->scheme != "sim")
    return fail(Errc::unsupported, "source '" + spec_text +
                                       "': mimic run drives avatars from sim: sources in this build "
                                       "(tracker sources need the solver)");
  auto skeleton = avatar::Skeleton::build(avatar::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto motion = builtin_motion(spec->target.empty() ? "walk" : spec->target, *skeleton);
  if (!motion) return tl::unexpected(motion.error());
  sim::RigConfig cfg;
  auto param = [&](const char* key, const std::string& fallback) {
    auto it = spec->params.find(key);
    return it == spec->params.end() ? fallback : it->second;
  };
  auto layout = sim::make_layout(param("sensors", "6"), *skeleton);
  if (!layout) return tl::unexpected(layout.error());
  cfg.sensors = std::move(*layout);
  char* end = nullptr;
  const std::string rate = param("rate", "90");
  cfg.rate_hz = std::strtod(rate.c_str(), &end);
  if (*end != '\0' || !(cfg.rate_hz > 0 && cfg.rate_hz <= 1000))
    return fail(Errc::invalid_argument, "source '" + spec_text + "': rate must be in (0, 1000] Hz");
  const std::string seed = param("seed", "1");
  cfg.seed = std::strtoull(seed.c_str(), &end, 10);
  if (*end != '\0') return fail(Errc::invalid_argument, "source '" + spec_text + "': bad seed");
  cfg.position_noise_mm = 1.0;
  cfg.orientation_noise_deg = 0.5;
  auto rig = sim::SensorRig::create(*motion, cfg);
  if (!rig) return tl::unexpected(rig.error());
  const std::string desc = spec_text + " (" + std::to_string(cfg.sensors.size()) + " sensors, " +
                           rate + " Hz, seed " + seed + ")";
  auto source = std::make_unique<sim::SimSource>(std::move(*rig), std::make_shared<sim::SteadyClock>(), desc);
  return make_motion_feed(*motion, std::move(source), desc);
}

std::unique_ptr<Deformer> make_fk_deformer(const avatar::Skeleton& skeleton) {
  return std::make_unique<FkDeformer>(skeleton);
}

Result<std::string> load_body_model(const std::string& path, const avatar::Skeleton& skeleton) {
  if (!path.empty()) return read_file(path);
  // Default body until the metaball body model is serialised here: the skeleton it hangs on.
  nlohmann::json j;
  j["format"] = "mimic-body";
  j["version"] = 1;
  for (const auto& joint : skeleton.desc().joints) {
    nlohmann::json jj;
    jj["name"] = joint.name;
    jj["parent"] = joint.parent;
    jj["offset_m"] = {joint.offset_m.x, joint.offset_m.y, joint.offset_m.z};
    for (const auto& d : joint.dofs)
      jj["dofs"].push_back({{"name", d.name}, {"axis", {d.axis.x, d.axis.y, d.axis.z}}, {"min_rad", d.min_rad},
                            {"max_rad", d.max_rad}});
    j["skeleton"].push_back(jj);
  }
  return j.dump();
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
  if (auto st = feed->start(); !st) return st;
  a.pose = s.rest_pose();
  a.packet.resize(net::pose_packet_bytes(s.dof_count()));
  a.feed = std::move(feed);
  a.deformer = deformer ? std::move(deformer) : make_fk_deformer(s);
  avatars_.push_back(std::move(a));
  return {};
}

void Pipeline::tick() {
  using C = std::chrono::steady_clock;
  auto us = [](C::time_point a, C::time_point b) { return std::chrono::duration<double, std::micro>(b - a).count(); };
  for (size_t i = 0; i < avatars_.size(); ++i) {
    Avatar& a = avatars_[i];
    const auto t0 = C::now();
    const size_t n = a.feed->read();
    const auto t1 = C::now();
    timers_[kStageRead].add(us(t0, t1));
    if (n == 0) continue;
    double capture_s = 0;
    bool stale = false;
    a.feed->solve(a.pose, capture_s, stale);
    const auto t2 = C::now();
    a.deformer->deform(a.pose);
    const auto t3 = C::now();
    const double age_s = std::max(0.0, now_s() - capture_s);
    net::PoseHeader h;
    h.avatar = a.server_id;
    h.sequence = ++a.sequence;
    h.flags = stale ? net::kPoseStale : 0;
    h.time_us = net::wall_clock_us() - static_cast<uint64_t>(age_s * 1e6);
    const size_t bytes = net::encode_pose(h, a.pose, a.packet);
    const auto t4 = C::now();
    if (out_.server && bytes && out_.server->publish_pose(a.server_id, std::span<const uint8_t>(a.packet.data(), bytes)) != net::Reject::ok)
      send_failures_++;
    if (out_.publisher && a.publisher_slot >= 0 &&
        !out_.publisher->publish_pose(static_cast<uint8_t>(a.publisher_slot), h, a.pose))
      send_failures_++;
    if (out_.vmc && i == 0 && out_.vmc->send(a.pose, double(h.time_us) * 1e-6) == 0) send_failures_++;
    const auto t5 = C::now();
    timers_[kStageSolve].add(us(t1, t2));
    timers_[kStageDeform].add(us(t2, t3));
    timers_[kStageEncode].add(us(t3, t4));
    timers_[kStageSend].add(us(t4, t5));
    timers_[kStageLatency].add(std::max(0.0, now_s() - capture_s) * 1e6);
    frames_++;
  }
}

}  // namespace mimic::app
