// End-to-end: `mimic compare` reports the surface distance, `mimic fit` writes a body that the
// other commands take, and refuses bad input with a clear message.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "run_mimic.h"
#include "test_data.h"

namespace fit_cli_test {

namespace {

using ::mimic::test::Outcome;
using ::mimic::test::run_mimic;

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mimic_fit_cli_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

nlohmann::json distance_of(const std::string& body_args) {
  const Outcome r = run_mimic("compare --json --samples 5000 " + body_args, true);
  EXPECT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output, nullptr, false);
  return j.is_discarded() ? nlohmann::json() : j["surface_distance"];
}

TEST(FitCli, CompareReportsTheSurfaceDistanceBothWaysAndPerRegion) {
  const auto d = distance_of("");
  ASSERT_TRUE(d.is_object());
  for (const char* side : {"body_to_reference_mm", "reference_to_body_mm"}) {
    // The built-in body, fitted to the MakeHuman mesh, lies 4-5 mm from it (docs/fit.md).
    EXPECT_GT(d[side]["mean"].get<double>(), 2.0) << d.dump();
    EXPECT_LT(d[side]["mean"].get<double>(), 5.5) << d.dump();
    for (const char* region : {"head", "torso", "arms", "hands", "legs", "feet"})
      EXPECT_TRUE(d[side]["regions"].contains(region)) << region << " " << d.dump();
  }
  const Outcome table = run_mimic("compare --samples 2000");
  EXPECT_EQ(table.status, 0) << table.output;
  EXPECT_NE(table.output.find("mean, hands"), std::string::npos) << table.output;
}

TEST(FitCli, AFittedBodyIsNearerAndWorksEverywhere) {
  const std::string out = temp("body.json"), obj = temp("fitted.obj");
  const Outcome r = run_mimic("fit --iterations 3 --samples 3000 --json --out " + out, true);
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["closed"], true) << r.output;
  EXPECT_EQ(j["missed_rays"], 0) << r.output;
  const auto before = distance_of(""), after = distance_of("--body " + out);
  // The built-in body is already fitted (3.8 / 4.0 mm); three more steps still bring it at least
  // 2% nearer (3.66 / 3.83 mm on 3000 samples: where they end depends on the samples) and within
  // 5 mm.
  for (const char* side : {"body_to_reference_mm", "reference_to_body_mm"}) {
    EXPECT_LT(after[side]["mean"].get<double>(), 0.98 * before[side]["mean"].get<double>()) << after.dump();
    EXPECT_LE(after[side]["mean"].get<double>(), 5.0) << after.dump();
  }
  const Outcome mesh = run_mimic("mesh --body " + out + " --motion walk --time 0.4 --out " + obj);
  EXPECT_EQ(mesh.status, 0) << mesh.output;
  std::filesystem::remove(out);
  std::filesystem::remove(obj);
}

// The built-in body's table: from the authored body, rigid parts held, symmetric, written as the
// C++ source the library compiles in; it names no rigid primitive.
// By default the head's, hands' and feet's primitives keep their modelled shapes (sized and placed
// with their links); asked, the fit moves them one by one too, and gets nearer the mesh's hands,
// feet and head (2.9 against 3.8 mm after two steps on 1000 samples).
struct HeldAndFree {
  Outcome held, free;
  int rigid_primitives_changed = 0;  // the left side and the head (a body file writes a mirror-symmetric pair once)
};

HeldAndFree fit_held_and_free(const std::string& steps) {
  const std::string held = temp("held.json"), free = temp("free.json");
  HeldAndFree r{run_mimic("fit " + steps + " --json --out " + held, true),
                run_mimic("fit " + steps + " --json --fit-rigid-shapes --out " + free, true)};
  EXPECT_EQ(r.held.status, 0) << r.held.output;
  EXPECT_EQ(r.free.status, 0) << r.free.output;
  if (r.held.status != 0 || r.free.status != 0) return r;
  const auto rigid_primitives = [](const std::string& path) {
    std::ifstream in(path);
    const auto body = nlohmann::json::parse(in);
    std::map<std::string, nlohmann::json> out;
    for (const auto& p : body["primitives"])
      if (p.contains("part")) out[p["name"].get<std::string>()] = p["state"];
    return out;
  };
  const auto held_body = rigid_primitives(held), free_body = rigid_primitives(free);
  for (const auto& [name, state] : held_body)
    if (free_body.count(name)) r.rigid_primitives_changed += state != free_body.at(name);
  std::filesystem::remove(held);
  std::filesystem::remove(free);
  return r;
}

TEST(FitCli, TheRigidPartsShapesAreFittedWhenAsked) {
  const HeldAndFree r = fit_held_and_free("--iterations 2 --samples 1000");
  EXPECT_GT(r.rigid_primitives_changed, 0) << "the rigid primitives move only when asked";
  if (r.held.status != 0 || r.free.status != 0) return;
  const auto d_held = nlohmann::json::parse(r.held.output)["after"],
             d_free = nlohmann::json::parse(r.free.output)["after"];
  EXPECT_LT(d_free["body_to_reference_mm"]["mean"].get<double>(), d_held["body_to_reference_mm"]["mean"].get<double>())
      << r.held.output << "\n"
      << r.free.output;
}

// The same two fits on one step and the fewest samples: the sanitizer run's stand-in for the test
// above (tests/sanitizer_skip.txt), which needs two steps on more samples to show the gain.
TEST(FitCli, TheRigidPartsShapesMoveWhenAsked) {
  const HeldAndFree r = fit_held_and_free("--iterations 1 --samples 500");
  EXPECT_GT(r.rigid_primitives_changed, 0) << r.free.output;
}

TEST(FitCli, EmitDefaultWritesTheTableOfOverrides) {
  const std::string table = temp("default_body_fit.cpp");
  const Outcome r = run_mimic("fit --emit-default " + table + " --iterations 1 --samples 2000 --hold neck_base", true);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream in(table);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  EXPECT_NE(s.find("std::string_view default_body_fit_json()"), std::string::npos) << s.substr(0, 400);
  EXPECT_NE(s.find("\"format\": \"mimic-body-overrides\""), std::string::npos);
  EXPECT_NE(s.find("\"l_quadriceps\""), std::string::npos);
  for (const char* rigid : {"\"l_palm\"", "\"cranium\"", "\"l_heel\""})
    EXPECT_EQ(s.find(rigid), std::string::npos) << rigid;
  EXPECT_EQ(run_mimic("fit --iterations 1").status, 2);  // neither --out nor --emit-default
  std::filesystem::remove(table);
}

TEST(FitCli, BadInputGetsAClearError) {
  const std::string out = temp("never.json");
  Outcome r = run_mimic("fit --mesh /nonexistent-mimic-dir/person.obj --joints x.csv --out " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("/nonexistent-mimic-dir/person.obj"), std::string::npos) << r.output;
  const std::string empty = temp("empty.obj");
  std::ofstream(empty) << "# nothing\n";
  r = run_mimic("fit --mesh " + empty + " --joints " + ::mimic::test::shared_data("mesh/makehuman_base_joints.csv") +
                " --out " + out);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no triangles"), std::string::npos) << r.output;
  r = run_mimic("fit --mesh " + empty + " --out " + out);  // a mesh of one's own needs its joints
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--joints"), std::string::npos) << r.output;
  r = run_mimic("fit");  // --out is required
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  std::filesystem::remove(empty);
}

}  // namespace

}  // namespace fit_cli_test
