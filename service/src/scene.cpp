#include "mimic/service/scene.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/motion.h"
#include "mimic/core/clock.h"
#include "mimic/sim/open_input.h"

namespace mimic::service {
namespace {

constexpr float kPi = 3.14159265f;

glm::vec3 forward_of(float heading_rad) { return {std::sin(heading_rad), 0.0f, std::cos(heading_rad)}; }

float wrap_angle(float a) {
  while (a > kPi) a -= 2 * kPi;
  while (a < -kPi) a += 2 * kPi;
  return a;
}

glm::vec3 clamp_to_room(glm::vec3 p, const Room& room, float margin_m) {
  p.x = std::clamp(p.x, -room.half_width_m + margin_m, room.half_width_m - margin_m);
  p.z = std::clamp(p.z, -room.half_depth_m + margin_m, room.half_depth_m - margin_m);
  return p;
}

// The pose turned by the placement's heading and moved to its position.
void apply_placement(const Placement& place, rig::Pose& pose) {
  const glm::quat turn = glm::angleAxis(place.heading_rad, glm::vec3(0, 1, 0));
  pose.root_position_m = place.position_m + turn * pose.root_position_m;
  pose.root_orientation = glm::normalize(turn * pose.root_orientation);
}

// A number in [lo, hi]; false otherwise.
bool parse_number(const std::string& text, float lo, float hi, float& out) {
  try {
    size_t used = 0;
    const float v = std::stof(text, &used);
    if (used != text.size() || !std::isfinite(v) || v < lo || v > hi) return false;
    out = v;
    return true;
  } catch (...) {
    return false;
  }
}

}  // namespace

int SceneRoster::join() {
  where_.push_back({});
  return size() - 1;
}

void SceneRoster::set(int slot, const glm::vec3& position_m, float heading_rad) {
  if (slot < 0 || slot >= size()) return;
  where_[slot] = {glm::vec3(position_m.x, 0.0f, position_m.z), heading_rad};
}

float dead_zone(float value, float zone) {
  const float a = std::abs(value);
  if (a <= zone || zone >= 1.0f) return 0.0f;
  return std::copysign(std::min((a - zone) / (1.0f - zone), 1.0f), value);
}

Result<NavigationSpec> parse_navigation(const std::string& text) {
  NavigationSpec out;
  std::string device = text;
  const size_t q = text.find('?');
  if (q != std::string::npos) {
    device = text.substr(0, q);
    std::string kept;
    size_t start = q + 1;
    while (start <= text.size()) {
      size_t amp = text.find('&', start);
      if (amp == std::string::npos) amp = text.size();
      const std::string kv = text.substr(start, amp - start);
      const size_t eq = kv.find('=');
      const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
      bool ok = true;
      if (key == "speed")
        ok = parse_number(value, 0.0f, 20.0f, out.options.translation_speed_mps);
      else if (key == "turn")
        ok = parse_number(value, 0.0f, 20.0f, out.options.rotation_speed_radps);
      else if (key == "dead")
        ok = parse_number(value, 0.0f, 0.95f, out.options.dead_zone);
      else if (!kv.empty())
        kept.append(kept.empty() ? "" : "&").append(kv);
      if (!ok)
        return fail(Errc::invalid_argument, "--navigate " + text + ": " + key +
                                                " must be a number (speed 0..20 m/s, turn 0..20 rad/s, dead 0..0.95)");
      start = amp + 1;
    }
    if (!kept.empty()) device.append("?").append(kept);
  }
  auto spec = devices::parse_source_spec(device);
  if (!spec) return tl::unexpected(spec.error());
  if (spec->scheme != "spaceball" && spec->scheme != "magellan" && spec->scheme != "spacemouse")
    return fail(Errc::invalid_argument,
                "--navigate takes a 6-DOF device (spaceball:, magellan:, spacemouse), not " + text);
  out.device = std::move(*spec);
  return out;
}

void navigate(const devices::InputFrame& input, const NavigationOptions& o, float dt_s, const Room& room,
              Placement& place) {
  const float turn = dead_zone(input.rotation.y, o.dead_zone);
  const float ahead = -dead_zone(input.translation.z, o.dead_zone);  // pushing away: forward
  const float slide = dead_zone(input.translation.x, o.dead_zone);   // to the user's right
  place.heading_rad = wrap_angle(place.heading_rad + turn * o.rotation_speed_radps * dt_s);
  const glm::vec3 forward = forward_of(place.heading_rad);
  const glm::vec3 right = {-forward.z, 0.0f, forward.x};  // the avatar's right (−X when facing +Z)
  place.position_m += (ahead * forward + slide * right) * (o.translation_speed_mps * dt_s);
  place.position_m = clamp_to_room(place.position_m, room, 0.3f);
}

namespace {

class PlacedFeed final : public PoseFeed {
 public:
  PlacedFeed(std::unique_ptr<PoseFeed> inner, Placement place, std::shared_ptr<SceneRoster> roster, int slot,
             std::unique_ptr<devices::InputSource> navigator, NavigationOptions navigation)
      : inner_(std::move(inner)),
        place_(place),
        roster_(std::move(roster)),
        slot_(slot),
        navigator_(std::move(navigator)),
        navigation_(navigation) {
    placed_.reserve(64);
  }

  const rig::Skeleton& skeleton() const override { return inner_->skeleton(); }
  std::string describe() const override {
    return inner_->describe() + (navigator_ ? ", navigated by " + navigator_->status().description : "");
  }
  Status start() override {
    if (navigator_) {
      if (auto st = navigator_->start(); !st) return st;
    }
    return inner_->start();
  }
  size_t read() override { return inner_->read(); }
  void solve(rig::Pose& pose, double& capture_s, bool& stale) override {
    inner_->solve(pose, capture_s, stale);
    if (navigator_) {
      const double t = steady_now_s();
      devices::InputFrame frame;
      while (navigator_->poll(frame)) {
        input_ = frame;
        last_input_s_ = t;
      }
      // A device that stopped talking must not keep the avatar drifting: a deflected cap keeps
      // reporting (every few tens of milliseconds), so half a second of silence means released
      // or gone. (Asking status() here would copy strings: the loop does not allocate.)
      if (t - last_input_s_ > 0.5) input_ = {};
      const float dt_s = last_s_ > 0 ? static_cast<float>(std::clamp(t - last_s_, 0.0, 0.1)) : 0.0f;
      last_s_ = t;
      navigate(input_, navigation_, dt_s, roster_->room(), place_);
    }
    apply_placement(place_, pose);
    roster_->set(slot_, pose.root_position_m, place_.heading_rad);
    // The sensors move with the avatar (capacity reserved at setup: no allocation).
    const auto samples = inner_->latest_samples();
    placed_.resize(std::min(samples.size(), placed_.capacity()));
    const glm::quat turn = glm::angleAxis(place_.heading_rad, glm::vec3(0, 1, 0));
    for (size_t i = 0; i < placed_.size(); ++i) {
      placed_[i] = samples[i];
      placed_[i].position_m = place_.position_m + turn * samples[i].position_m;
      placed_[i].orientation = turn * samples[i].orientation;
    }
  }
  devices::DeviceStatus status() const override { return inner_->status(); }
  std::span<const devices::SensorSample> latest_samples() const override { return placed_; }

 private:
  std::unique_ptr<PoseFeed> inner_;
  Placement place_;
  std::shared_ptr<SceneRoster> roster_;
  int slot_;
  std::unique_ptr<devices::InputSource> navigator_;
  NavigationOptions navigation_;
  devices::InputFrame input_;
  double last_s_ = 0, last_input_s_ = 0;
  std::vector<devices::SensorSample> placed_;
};

}  // namespace

std::unique_ptr<PoseFeed> place_in_scene(std::unique_ptr<PoseFeed> feed, Placement placement,
                                         std::shared_ptr<SceneRoster> roster, int slot,
                                         std::unique_ptr<devices::InputSource> navigator,
                                         NavigationOptions navigation) {
  return std::make_unique<PlacedFeed>(std::move(feed), placement, std::move(roster), slot, std::move(navigator),
                                      navigation);
}

// ---- actors ----

Result<ActorOptions> actor_options(const std::string& spec_text, int slot_count_hint) {
  // actor:BEHAVIOUR?key=value&... (own scheme: actors are not devices).
  const std::string prefix = "actor:";
  if (spec_text.rfind(prefix, 0) != 0) return fail(Errc::invalid_argument, "not an actor spec: " + spec_text);
  std::string rest = spec_text.substr(prefix.size());
  std::string query;
  if (const size_t q = rest.find('?'); q != std::string::npos) {
    query = rest.substr(q + 1);
    rest = rest.substr(0, q);
  }
  ActorOptions o;
  if (rest == "wander" || rest.empty())
    o.behaviour = ActorOptions::Behaviour::wander;
  else if (rest == "follow")
    o.behaviour = ActorOptions::Behaviour::follow;
  else if (rest == "greet")
    o.behaviour = ActorOptions::Behaviour::greet;
  else
    return fail(Errc::invalid_argument, "unknown actor behaviour '" + rest + "' (wander, follow, greet)");
  size_t start = 0;
  while (start < query.size()) {
    size_t amp = query.find('&', start);
    if (amp == std::string::npos) amp = query.size();
    const std::string kv = query.substr(start, amp - start);
    const size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq), value = eq == std::string::npos ? "" : kv.substr(eq + 1);
    try {
      if (key == "seed")
        o.seed = std::stoull(value);
      else if (key == "target")
        o.target = std::stoi(value) - 1;
      else if (key == "x")
        o.start.position_m.x = std::stof(value);
      else if (key == "z")
        o.start.position_m.z = std::stof(value);
      else if (key == "heading")
        o.start.heading_rad = std::stof(value) * kPi / 180.0f;
      else
        return fail(Errc::invalid_argument,
                    spec_text + ": unknown actor parameter '" + key + "' (seed, target, x, z, heading)");
    } catch (...) {
      return fail(Errc::invalid_argument, spec_text + ": '" + value + "' is not a number for " + key);
    }
    start = amp + 1;
  }
  if (o.behaviour == ActorOptions::Behaviour::follow &&
      (o.target < 0 || (slot_count_hint > 0 && o.target >= slot_count_hint)))
    return fail(Errc::invalid_argument, spec_text + ": follow needs target=K, an avatar number from 1");
  return o;
}

ActorBrain::ActorBrain(ActorOptions options, float walk_speed_mps)
    : options_(options), placement_(options.start), walk_speed_mps_(walk_speed_mps) {
  std::mt19937_64 rng(options.seed);
  for (float& p : phase_) p = static_cast<float>(rng() % 10000) * 2e-4f * kPi;
}

void ActorBrain::step(float dt_s, SceneRoster& roster, int self) {
  if (dt_s <= 0) return;
  time_s_ += dt_s;
  const float t = static_cast<float>(time_s_);
  const Room& room = roster.room();
  glm::vec3& pos = placement_.position_m;
  glm::vec3 dir = forward_of(placement_.heading_rad);
  bool want_walk = true;

  // The nearest other avatar.
  int nearest = -1;
  float nearest_m = 1e9f;
  for (int i = 0; i < roster.size(); ++i) {
    if (i == self) continue;
    const float d = glm::length(roster.position(i) - pos);
    if (d < nearest_m) {
      nearest_m = d;
      nearest = i;
    }
  }
  auto wander_dir = [&] {
    // Smooth pseudo-random turning: a sum of slow sines, different per seed.
    const float turn_radps = 0.7f * std::sin(0.31f * t + phase_[0]) + 0.5f * std::sin(0.83f * t + phase_[1]) +
                             0.3f * std::sin(1.7f * t + phase_[2]);
    return forward_of(placement_.heading_rad + turn_radps * dt_s * 4.0f);
  };
  auto face = [&](const glm::vec3& target) {
    const glm::vec3 d = target - pos;
    if (glm::length(d) > 1e-3f) dir = glm::normalize(glm::vec3(d.x, 0, d.z));
  };

  switch (options_.behaviour) {
    case ActorOptions::Behaviour::wander: dir = wander_dir(); break;
    case ActorOptions::Behaviour::follow:
      if (options_.target >= 0 && options_.target < roster.size() && options_.target != self) {
        const glm::vec3 target = roster.position(options_.target);
        face(target);
        want_walk = glm::length(target - pos) > 1.6f;
      } else {
        dir = wander_dir();
      }
      break;
    case ActorOptions::Behaviour::greet:
      if (wave_s_ > 0) {
        wave_s_ -= dt_s;
        want_walk = false;
        if (nearest >= 0) face(roster.position(nearest));
        if (wave_s_ <= 0) cooldown_s_ = 8.0f;
      } else if (cooldown_s_ > 0 || nearest < 0) {
        cooldown_s_ = std::max(0.0f, cooldown_s_ - dt_s);
        dir = wander_dir();
      } else {
        face(roster.position(nearest));
        if (nearest_m < 1.5f) {
          wave_s_ = 3.0f;
          want_walk = false;
        }
      }
      break;
  }

  // Avoid the others: steer away from anyone close, brake for anyone just ahead.
  float brake = 1.0f;
  if (want_walk) {
    glm::vec3 away(0.0f);
    for (int i = 0; i < roster.size(); ++i) {
      if (i == self) continue;
      glm::vec3 d = pos - roster.position(i);
      d.y = 0;
      const float dist = glm::length(d);
      if (dist < 1e-4f || dist > 1.6f) continue;
      away += d / (dist * dist);
      if (glm::dot(forward_of(placement_.heading_rad), -d / dist) > 0.3f)
        brake = std::min(brake, std::clamp((dist - 0.7f) / 0.6f, 0.0f, 1.0f));
    }
    dir += 0.9f * away;
    // Stay in the room: turn back from the walls, harder the closer they are.
    const float margin = 1.0f;
    if (pos.x > room.half_width_m - margin) dir.x -= 3.0f * (pos.x - (room.half_width_m - margin));
    if (pos.x < -room.half_width_m + margin) dir.x += 3.0f * (-room.half_width_m + margin - pos.x);
    if (pos.z > room.half_depth_m - margin) dir.z -= 3.0f * (pos.z - (room.half_depth_m - margin));
    if (pos.z < -room.half_depth_m + margin) dir.z += 3.0f * (-room.half_depth_m + margin - pos.z);
  }
  if (glm::length(dir) > 1e-4f) {
    const float wanted = std::atan2(dir.x, dir.z);
    const float max_turn = 2.5f * dt_s;
    placement_.heading_rad = wrap_angle(placement_.heading_rad +
                                        std::clamp(wrap_angle(wanted - placement_.heading_rad), -max_turn, max_turn));
  }
  walking_ = std::clamp(walking_ + (want_walk ? 2.0f : -2.0f) * dt_s, 0.0f, 1.0f);
  pos += forward_of(placement_.heading_rad) * (walk_speed_mps_ * walking_ * brake * dt_s);
  pos = clamp_to_room(pos, room, 0.3f);
  roster.set(self, pos, placement_.heading_rad);
}

namespace {

// Built-in motion with its own travel taken out: the heading and the horizontal root position
// are the actor's to set.
void strip_travel(rig::Pose& pose) {
  const glm::vec3 f = pose.root_orientation * glm::vec3(0, 0, 1);
  const float yaw = std::atan2(f.x, f.z);
  pose.root_orientation = glm::normalize(glm::angleAxis(-yaw, glm::vec3(0, 1, 0)) * pose.root_orientation);
  pose.root_position_m.x = 0;
  pose.root_position_m.z = 0;
}

class ActorFeed final : public PoseFeed {
 public:
  ActorFeed(rig::Skeleton skeleton, std::unique_ptr<rig::Motion> walk, std::unique_ptr<rig::Motion> idle,
            ActorOptions options, float speed_mps, std::shared_ptr<SceneRoster> roster, int slot, std::string text)
      : skeleton_(std::move(skeleton)),
        walk_(std::move(walk)),
        idle_(std::move(idle)),
        brain_(options, speed_mps),
        roster_(std::move(roster)),
        slot_(slot),
        text_(std::move(text)) {
    walk_pose_ = walk_->skeleton().zero_pose();
    idle_pose_ = idle_->skeleton().zero_pose();
    wave_dof_ = skeleton_.find_dof("r_shoulder_abduction");
    elbow_dof_ = skeleton_.find_dof("r_elbow_flexion");
    roster_->set(slot_, options.start.position_m, options.start.heading_rad);
  }
  const rig::Skeleton& skeleton() const override { return skeleton_; }
  std::string describe() const override { return "actor " + text_; }
  Status start() override {
    last_s_ = steady_now_s();
    return {};
  }
  size_t read() override {
    // A new pose every 10 ms, like a 100 Hz tracker.
    const double t = steady_now_s();
    if (t - last_s_ < 0.01) return 0;
    pending_s_ = t - last_s_;
    last_s_ = t;
    ++records_;
    return 1;
  }
  void solve(rig::Pose& pose, double& capture_s, bool& stale) override {
    const float dt_s = static_cast<float>(std::min(pending_s_, 0.1));
    brain_.step(dt_s, *roster_, slot_);
    const float w = brain_.walking();
    walk_time_s_ += dt_s * w;  // the legs slow down to a stop with the body
    idle_time_s_ += dt_s;
    walk_->sample(walk_time_s_, walk_pose_);
    idle_->sample(idle_time_s_, idle_pose_);
    strip_travel(walk_pose_);
    strip_travel(idle_pose_);
    if (pose.dof_rad.size() != idle_pose_.dof_rad.size()) pose = idle_pose_;
    for (size_t i = 0; i < pose.dof_rad.size(); ++i)
      pose.dof_rad[i] = idle_pose_.dof_rad[i] + w * (walk_pose_.dof_rad[i] - idle_pose_.dof_rad[i]);
    pose.root_position_m = glm::mix(idle_pose_.root_position_m, walk_pose_.root_position_m, w);
    pose.root_orientation = glm::slerp(idle_pose_.root_orientation, walk_pose_.root_orientation, w);
    if (brain_.waving() && wave_dof_ >= 0 && elbow_dof_ >= 0) {
      pose.dof_rad[wave_dof_] = 2.3f;
      pose.dof_rad[elbow_dof_] = 0.5f + 0.4f * std::sin(static_cast<float>(idle_time_s_) * 9.0f);
    }
    apply_placement(brain_.placement(), pose);
    capture_s = last_s_;
    stale = false;
  }
  devices::DeviceStatus status() const override {
    devices::DeviceStatus s;
    s.state = devices::DeviceState::streaming;
    s.description = "actor " + text_;
    s.records = records_;
    return s;
  }

 private:
  rig::Skeleton skeleton_;
  std::unique_ptr<rig::Motion> walk_, idle_;
  ActorBrain brain_;
  std::shared_ptr<SceneRoster> roster_;
  int slot_;
  std::string text_;
  rig::Pose walk_pose_, idle_pose_;
  int wave_dof_ = -1, elbow_dof_ = -1;
  double last_s_ = 0, pending_s_ = 0, walk_time_s_ = 0, idle_time_s_ = 0;
  uint64_t records_ = 0;
};

// Metres per second the built-in walk covers (its root's path over a few seconds).
float walk_speed(const rig::Motion& walk) {
  rig::Pose p = walk.skeleton().zero_pose();
  walk.sample(0.0, p);
  glm::vec3 prev = p.root_position_m;
  float path_m = 0;
  const double span_s = 4.0;
  for (int i = 1; i <= 400; ++i) {
    walk.sample(span_s * i / 400.0, p);
    const glm::vec3 d = p.root_position_m - prev;
    path_m += glm::length(glm::vec2(d.x, d.z));
    prev = p.root_position_m;
  }
  return std::clamp(path_m / static_cast<float>(span_s), 0.3f, 2.0f);
}

}  // namespace

Result<std::unique_ptr<PoseFeed>> make_actor_feed(const std::string& spec_text, std::shared_ptr<SceneRoster> roster,
                                                  int slot, const rig::Skeleton* body) {
  auto options = actor_options(spec_text, roster->size());
  if (!options) return tl::unexpected(options.error());
  auto skeleton = body ? Result<rig::Skeleton>(*body) : rig::Skeleton::build(rig::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto walk = rig::make_builtin_motion("walk", *skeleton);
  if (!walk) return tl::unexpected(walk.error());
  auto idle = rig::make_builtin_motion("idle", *skeleton);
  if (!idle) return tl::unexpected(idle.error());
  const float speed = walk_speed(**walk);
  return std::unique_ptr<PoseFeed>(std::make_unique<ActorFeed>(std::move(*skeleton), std::move(*walk), std::move(*idle),
                                                               *options, speed, std::move(roster), slot, spec_text));
}

}  // namespace mimic::service
