// The shared scene of the paper's VLNET (§4.4): several avatars in one room. Each avatar's
// feed is wrapped so its poses are placed in the room (a position on the floor and a heading);
// a 6-DOF device (Spaceball, SpaceMouse, Magellan, or the virtual one) may move that placement
// as spacenavd users expect (speeds at full deflection, a dead zone); autonomous actors walk
// the room with the built-in motions, avoid the others and stay inside. A roster holds where
// every avatar stands, written as each feed solves and read by the actors.
//
// World frame: metres, +Y up; heading_rad turns about +Y, 0 faces +Z. The room is centred on
// the origin.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/devices/source.h"
#include "mimic/service/pipeline.h"

namespace mimic::service {

struct Room {
  float half_width_m = 4.0f;  // x in [-half_width, half_width]
  float half_depth_m = 4.0f;  // z likewise
};

struct Placement {
  glm::vec3 position_m{0.0f};  // on the floor (y is added to the pose's own root height)
  float heading_rad = 0.0f;
};

// Where every avatar of the scene stands: slot i is the i-th avatar added.
class SceneRoster {
 public:
  explicit SceneRoster(Room room = {}) : room_(room) {}
  int join();  // setup only
  void set(int slot, const glm::vec3& position_m, float heading_rad);
  int size() const { return static_cast<int>(where_.size()); }
  const glm::vec3& position(int slot) const { return where_[slot].position_m; }
  float heading(int slot) const { return where_[slot].heading_rad; }
  const Room& room() const { return room_; }

 private:
  Room room_;
  std::vector<Placement> where_;
};

// Spacenavd-like navigation: deflections below the dead zone (fraction of full scale) read as
// zero, the rest is rescaled to [0, 1]; full deflection moves at the given speeds. Forward is
// pushing the cap away from you (−Z of the device), left/right slides (X), twisting the cap
// about its vertical axis turns (+RY turns left). Height and tilt are ignored: avatars stay on
// the floor.
struct NavigationOptions {
  float translation_speed_mps = 1.2f;
  float rotation_speed_radps = 1.6f;
  float dead_zone = 0.08f;
};
// "spaceball:PATH?speed=1.2&turn=1.6&dead=0.08", "spacemouse[:...]", "magellan:PATH": the
// navigation keys (speed, turn, dead) are taken out, the rest names the device.
struct NavigationSpec {
  devices::SourceSpec device;
  NavigationOptions options;
};
Result<NavigationSpec> parse_navigation(const std::string& text);
// The device reading after the dead zone: each axis in [-1, 1].
float dead_zone(float value, float zone);
// Moves `placement` by one device frame held for dt_s, inside `room`.
void navigate(const devices::InputFrame& input, const NavigationOptions& options, float dt_s, const Room& room,
              Placement& placement);

// Wraps a feed: its poses are turned by the placement's heading and moved to its position,
// and its place is written to roster slot `slot` at every solve. With `navigator`, the
// placement follows that device.
std::unique_ptr<PoseFeed> place_in_scene(std::unique_ptr<PoseFeed> feed, Placement placement,
                                         std::shared_ptr<SceneRoster> roster, int slot,
                                         std::unique_ptr<devices::InputSource> navigator = nullptr,
                                         NavigationOptions navigation = {});

// Autonomous actors: "actor:wander?seed=N" walks about at random; "actor:follow?target=K"
// walks after avatar K (1-based, as `mimic run` numbers them) and waits beside it;
// "actor:greet" walks up to the nearest avatar, stops and waves, then wanders off for a while.
// All avoid the others and stay in the room. They move with the built-in walk (and idle when
// standing), on Mimic's default skeleton.
struct ActorOptions {
  enum class Behaviour { wander, follow, greet } behaviour = Behaviour::wander;
  int target = -1;  // follow: the roster slot followed
  uint64_t seed = 1;
  Placement start;
};
Result<ActorOptions> actor_options(const std::string& spec_text, int slot_count_hint = 0);

// The steering of one actor, apart from poses and clocks so it can be stepped in tests.
class ActorBrain {
 public:
  ActorBrain(ActorOptions options, float walk_speed_mps);
  // Advances dt_s: decides where to go given the others in `roster` (its own slot skipped),
  // moves, and writes its place there.
  void step(float dt_s, SceneRoster& roster, int self);
  const Placement& placement() const { return placement_; }
  float walking() const { return walking_; }  // 0 standing .. 1 walking (blended)
  bool waving() const { return wave_s_ > 0; }

 private:
  ActorOptions options_;
  Placement placement_;
  float walk_speed_mps_;
  float walking_ = 0.0f;
  double time_s_ = 0.0;
  float wave_s_ = 0.0f, cooldown_s_ = 0.0f;
  float phase_[3];
};

// `body`, when given, is the skeleton the actor walks with (its body model's); else the default.
Result<std::unique_ptr<PoseFeed>> make_actor_feed(const std::string& spec_text, std::shared_ptr<SceneRoster> roster,
                                                  int slot, const rig::Skeleton* body = nullptr);

}  // namespace mimic::service
