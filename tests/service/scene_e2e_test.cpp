// End-to-end: `mimic run` serving one scene with actors and a Spaceball-navigated avatar,
// watched through a real subscriber over loopback.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/skin.h"
#include "mimic/net/client.h"
#include "run_mimic.h"
#include "test_data.h"

namespace scene_e2e_test {

namespace {

using Clock = std::chrono::steady_clock;

std::string endpoint_of(mimic::test::Child& run) {
  const std::string line = run.line();
  const std::string prefix = "serving on ";
  return line.rfind(prefix, 0) == 0 ? line.substr(prefix.size()) : "";
}

// Root positions of every avatar, one sample per pose frame, for `seconds`.
std::map<uint16_t, std::vector<glm::vec3>> watch(const std::string& endpoint, double seconds) {
  std::map<uint16_t, std::vector<glm::vec3>> track;
  mimic::net::ClientOptions o;
  o.connect = endpoint;
  o.name = "scene-test";
  auto client = mimic::net::Client::connect(o);
  EXPECT_TRUE(client) << (client ? "" : client.error().what());
  if (!client) return track;
  (*client)->on_pose = [&](const mimic::net::RemoteAvatar& a, uint64_t) {
    track[a.id].push_back(a.pose.root_position_m);
  };
  (*client)->run_until(Clock::now() + std::chrono::milliseconds(static_cast<int>(seconds * 1000)));
  return track;
}

float path_m(const std::vector<glm::vec3>& t) {
  float s = 0;
  for (size_t i = 1; i < t.size(); ++i) s += glm::length(glm::vec2(t[i].x - t[i - 1].x, t[i].z - t[i - 1].z));
  return s;
}

TEST(SceneE2e, ActorsWalkTheRoomKeepApartAndFollow) {
  mimic::test::Child run({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--room", "6x6", "--source",
                          "sim:idle", "--place", "0,1.5", "--source", "actor:wander?seed=3", "--source",
                          "actor:follow?target=1", "--source", "actor:greet?seed=4", "--duration", "20", "--quiet"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty());
  const auto track = watch(ep, 8.0);
  ASSERT_EQ(track.size(), 4u);
  std::vector<const std::vector<glm::vec3>*> tracks;
  for (const auto& [id, t] : track) {
    ASSERT_GT(t.size(), 200u) << "avatar " << id;
    tracks.push_back(&t);
    for (const glm::vec3& p : t) {
      EXPECT_LE(std::abs(p.x), 3.0f) << "avatar " << id;
      EXPECT_LE(std::abs(p.z), 3.0f) << "avatar " << id;
    }
  }
  // The participant stands where it was placed; the wanderer walks.
  EXPECT_NEAR(tracks[0]->back().z, 1.5f, 0.3f);
  EXPECT_GT(path_m(*tracks[1]), 3.0f);
  // The follower ends up near the participant (it started 3 m away and walks at ~1 m/s).
  EXPECT_LT(
      glm::length(glm::vec2(tracks[2]->back().x - tracks[0]->back().x, tracks[2]->back().z - tracks[0]->back().z)),
      2.6f);
  // Nobody walks into anybody: frames of different avatars at about the same index.
  float closest = 1e9f;
  const size_t n = std::min({tracks[0]->size(), tracks[1]->size(), tracks[2]->size(), tracks[3]->size()});
  for (size_t k = 0; k < n; ++k)
    for (size_t i = 0; i < tracks.size(); ++i)
      for (size_t j = i + 1; j < tracks.size(); ++j) {
        const glm::vec3 d = (*tracks[i])[k] - (*tracks[j])[k];
        closest = std::min(closest, glm::length(glm::vec2(d.x, d.z)));
      }
  EXPECT_GT(closest, 0.35f);
}

TEST(SceneE2e, ASpaceballMovesTheAvatarThroughTheRoom) {
  mimic::test::Child ball({mimic::test::mimic_binary(), "sim", "spaceball", "--seed", "7", "--power-up", "0.2"});
  const std::string pty = ball.line();
  ASSERT_EQ(pty.rfind("/dev/", 0), 0u) << pty;
  mimic::test::Child run({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--source", "sim:idle",
                          "--navigate", "spaceball:" + pty + "?dead=0.02&speed=2", "--source", "sim:idle?seed=2",
                          "--duration", "20", "--quiet"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty());
  const auto track = watch(ep, 8.0);
  ASSERT_EQ(track.size(), 2u);
  const auto& navigated = track.begin()->second;
  const auto& standing = std::next(track.begin())->second;
  ASSERT_GT(navigated.size(), 100u);
  // The navigated avatar travels; the other one, on the same idle motion, stays put.
  EXPECT_GT(path_m(navigated), 0.5f);
  EXPECT_LT(glm::length(standing.back() - standing.front()), 0.2f);
}

TEST(SceneE2e, BodiesOfEverySizeStandOnTheFloor) {
  // Each avatar's source is solved on its own body's skeleton: a viewer deforming the body it
  // was sent with the poses it gets finds the soles on the floor, tall or small, standing or
  // walking (solved on the default skeleton instead, the tall body sank ~0.2 m, the child floated).
  mimic::test::Child run({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--source", "sim:idle",
                          "--body", "preset:tall", "--source", "sim:idle?seed=2", "--body", "preset:child", "--source",
                          "actor:wander", "--body", "preset:heavy", "--duration", "20", "--quiet"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty());
  mimic::net::ClientOptions o;
  o.connect = ep;
  o.name = "floor-test";
  auto client = mimic::net::Client::connect(o);
  ASSERT_TRUE(client) << client.error().what();
  std::map<uint16_t, mimic::net::RemoteAvatar> latest;
  (*client)->on_pose = [&](const mimic::net::RemoteAvatar& a, uint64_t) { latest[a.id] = a; };
  (*client)->run_until(Clock::now() + std::chrono::seconds(3));
  ASSERT_EQ(latest.size(), 3u);
  std::vector<std::string> names;
  for (const auto& [id, a] : latest) {
    auto model = mimic::avatar::body_model_from_json(a.model_bytes);
    ASSERT_TRUE(model) << model.error().what();
    names.push_back(model->name);
    auto skeleton = mimic::rig::Skeleton::build(model->skeleton);
    ASSERT_TRUE(skeleton);
    auto skin = mimic::avatar::ImplicitSkin::create(*model, *skeleton);
    ASSERT_TRUE(skin) << skin.error().what();
    skin->evaluate(a.pose);
    float sole_m = 1e9f;
    for (const glm::vec3& p : skin->mesh().positions) sole_m = std::min(sole_m, p.y);
    EXPECT_NEAR(sole_m, 0.0f, 0.04f) << model->name;
  }
  EXPECT_EQ(names, (std::vector<std::string>{"tall", "child", "heavy"}));
}

TEST(SceneE2e, TheLoopStaysAllocationFreeWithActorsAndNavigation) {
  const mimic::test::Outcome r = mimic::test::run_mimic(
      "run --listen 127.0.0.1:0 --source sim:idle --navigate spacemouse:sim --source actor:wander "
      "--source 'actor:follow?target=1' --source actor:greet --duration 3 --quiet --json",
      true);
  ASSERT_EQ(r.status, 0) << r.output;
  const size_t at = r.output.find("\"loop_allocations\":");
  ASSERT_NE(at, std::string::npos) << r.output;
  EXPECT_EQ(std::stoul(r.output.substr(at + std::string("\"loop_allocations\":").size())), 0u)
      << r.output.substr(at, 40);
}

TEST(SceneE2e, BadSceneOptionsGetClearErrors) {
  mimic::test::Outcome r = mimic::test::run_mimic("run --listen 127.0.0.1:0 --source actor:dance --duration 1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("dance"), std::string::npos) << r.output;
  r = mimic::test::run_mimic("run --listen 127.0.0.1:0 --source sim:idle --navigate sim:walk --duration 1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("6-DOF"), std::string::npos) << r.output;
  r = mimic::test::run_mimic("run --listen 127.0.0.1:0 --source sim:idle --place 1 --duration 1");
  EXPECT_EQ(r.status, 2);
  r = mimic::test::run_mimic("run --listen 127.0.0.1:0 --room 1x1 --duration 1");
  EXPECT_EQ(r.status, 2);
  r = mimic::test::run_mimic("run --listen 127.0.0.1:0 --source 'actor:follow?target=5' --duration 1");
  EXPECT_EQ(r.status, 2);
}

}  // namespace

}  // namespace scene_e2e_test
