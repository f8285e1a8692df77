// The shared scene: placement, spacenavd-like navigation, and the actors' steering stepped in
// simulated time (properties over long seeded runs: inside the room, apart from the others).
#include <gtest/gtest.h>

#include <cmath>

#include "mimic/service/scene.h"

namespace scene_test {

namespace {

using namespace mimic::service;

TEST(Navigation, DeadZoneZeroesSmallDeflectionsAndRescalesTheRest) {
  EXPECT_EQ(dead_zone(0.05f, 0.08f), 0.0f);
  EXPECT_EQ(dead_zone(-0.08f, 0.08f), 0.0f);
  EXPECT_NEAR(dead_zone(1.0f, 0.08f), 1.0f, 1e-6f);
  EXPECT_NEAR(dead_zone(-1.0f, 0.08f), -1.0f, 1e-6f);
  EXPECT_NEAR(dead_zone(0.54f, 0.08f), 0.5f, 1e-6f);  // continuous past the edge of the zone
  EXPECT_NEAR(dead_zone(2.0f, 0.0f), 1.0f, 1e-6f);    // clamped to full scale
}

TEST(Navigation, PushingAwayWalksForwardTwistingTurnsAndTheRoomHolds) {
  NavigationOptions o;  // 1.2 m/s, 1.6 rad/s, dead zone 0.08
  const Room room;
  Placement p;
  mimic::devices::InputFrame push;
  push.translation.z = -1.0f;  // cap pushed away from the user
  for (int i = 0; i < 100; ++i) navigate(push, o, 0.01f, room, p);
  EXPECT_NEAR(p.position_m.z, 1.2f, 1e-3f);  // one second forward: +Z, where the avatar faces
  EXPECT_NEAR(p.position_m.x, 0.0f, 1e-4f);
  mimic::devices::InputFrame twist;
  twist.rotation.y = 1.0f;  // counter-clockwise seen from above: turn left
  for (int i = 0; i < 100; ++i) navigate(twist, o, 0.01f, room, p);
  EXPECT_NEAR(p.heading_rad, 1.6f, 1e-3f);
  EXPECT_NEAR(p.position_m.z, 1.2f, 1e-3f);  // turning in place
  // Now facing about +X (its left): pushing forward moves along +X.
  const glm::vec3 before = p.position_m;
  for (int i = 0; i < 50; ++i) navigate(push, o, 0.01f, room, p);
  EXPECT_GT(p.position_m.x - before.x, 0.5f);
  // Inside the dead zone nothing moves; a long push stops at the wall.
  mimic::devices::InputFrame small;
  small.translation.z = -0.05f;
  const Placement still = p;
  for (int i = 0; i < 100; ++i) navigate(small, o, 0.01f, room, p);
  EXPECT_EQ(p.position_m, still.position_m);
  for (int i = 0; i < 2000; ++i) navigate(push, o, 0.01f, room, p);
  EXPECT_LE(p.position_m.x, room.half_width_m);
}

TEST(Navigation, OptionsParseAndRejectNonsense) {
  auto n = parse_navigation("spaceball:/dev/null?speed=2&turn=0.5&dead=0.2&baud=9600");
  ASSERT_TRUE(n) << n.error().what();
  EXPECT_FLOAT_EQ(n->options.translation_speed_mps, 2.0f);
  EXPECT_FLOAT_EQ(n->options.rotation_speed_radps, 0.5f);
  EXPECT_FLOAT_EQ(n->options.dead_zone, 0.2f);
  EXPECT_EQ(n->device.scheme, "spaceball");
  EXPECT_EQ(n->device.target, "/dev/null");
  EXPECT_EQ(n->device.params.count("speed"), 0u);  // the device sees its own keys only
  EXPECT_FALSE(parse_navigation("spaceball:/dev/null?dead=1.5"));
  EXPECT_FALSE(parse_navigation("spaceball:/dev/null?speed=fast"));
  EXPECT_FALSE(parse_navigation("sim:walk"));  // not a 6-DOF device
}

TEST(Actors, SpecsParseAndBadOnesAreRefused) {
  auto w = actor_options("actor:wander?seed=7&x=1&z=-2");
  ASSERT_TRUE(w) << w.error().what();
  EXPECT_EQ(w->seed, 7u);
  EXPECT_FLOAT_EQ(w->start.position_m.z, -2.0f);
  auto f = actor_options("actor:follow?target=2", 3);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->target, 1);
  EXPECT_FALSE(actor_options("actor:follow", 3));           // no target
  EXPECT_FALSE(actor_options("actor:follow?target=9", 3));  // no such avatar
  EXPECT_FALSE(actor_options("actor:dance"));
  EXPECT_FALSE(actor_options("actor:wander?speed=3"));
}

// Several actors and two standing participants in a small room for five simulated minutes.
TEST(Actors, WanderersStayInTheRoomAndKeepApart) {
  SceneRoster roster(Room{3.0f, 2.5f});
  const int a = roster.join(), b = roster.join();
  roster.set(a, {-1.0f, 0, 0.5f}, 0);
  roster.set(b, {1.2f, 0, -0.5f}, 0);
  std::vector<ActorBrain> actors;
  std::vector<int> slots;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    ActorOptions o;
    o.seed = seed;
    o.start.position_m = {-2.0f + static_cast<float>(seed), 0, -1.8f};
    actors.emplace_back(o, 1.1f);
    slots.push_back(roster.join());
  }
  float closest_m = 1e9f;
  float travelled_m = 0;
  for (int tick = 0; tick < 300 * 100; ++tick) {
    for (size_t i = 0; i < actors.size(); ++i) {
      const glm::vec3 before = actors[i].placement().position_m;
      actors[i].step(0.01f, roster, slots[i]);
      travelled_m += glm::length(actors[i].placement().position_m - before);
      const glm::vec3 p = actors[i].placement().position_m;
      ASSERT_LE(std::abs(p.x), 3.0f) << tick;
      ASSERT_LE(std::abs(p.z), 2.5f) << tick;
    }
    for (int i = 0; i < roster.size(); ++i)
      for (int j = i + 1; j < roster.size(); ++j)
        closest_m = std::min(closest_m, glm::length(roster.position(i) - roster.position(j)));
  }
  EXPECT_GT(closest_m, 0.45f);                    // nobody walks into anybody
  EXPECT_GT(travelled_m, 4 * 300 * 1.1f * 0.4f);  // and they do walk, most of the time
}

TEST(Actors, AFollowerCatchesUpAndWaitsBeside) {
  SceneRoster roster;
  const int leader = roster.join();
  roster.set(leader, {3.0f, 0, 3.0f}, 0);
  ActorOptions o;
  o.behaviour = ActorOptions::Behaviour::follow;
  o.target = leader;
  o.start.position_m = {-3.0f, 0, -3.0f};
  ActorBrain follower(o, 1.1f);
  const int self = roster.join();
  for (int tick = 0; tick < 20 * 100; ++tick) follower.step(0.01f, roster, self);
  const float d = glm::length(follower.placement().position_m - roster.position(leader));
  EXPECT_LT(d, 1.9f);
  EXPECT_GT(d, 1.0f);
  EXPECT_LT(follower.walking(), 0.05f);  // arrived: standing
}

TEST(Actors, AGreeterWalksUpAndWaves) {
  SceneRoster roster;
  const int person = roster.join();
  roster.set(person, {0.0f, 0, 2.0f}, 0);
  ActorOptions o;
  o.behaviour = ActorOptions::Behaviour::greet;
  o.start.position_m = {0.0f, 0, -2.5f};
  ActorBrain greeter(o, 1.1f);
  const int self = roster.join();
  bool waved = false;
  for (int tick = 0; tick < 15 * 100 && !waved; ++tick) {
    greeter.step(0.01f, roster, self);
    waved = greeter.waving();
  }
  EXPECT_TRUE(waved);
  EXPECT_LT(glm::length(greeter.placement().position_m - roster.position(person)), 1.6f);
}

}  // namespace

}  // namespace scene_test
