// End-to-end: `mimic mesh` and `mimic compare`, the built program on the shared data.
#include <gtest/gtest.h>

#include <unistd.h>

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "mimic/avatar/mesh_check.h"
#include "mimic/avatar/mesh_io.h"
#include "run_mimic.h"
#include "test_data.h"

namespace mesh_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mimic_mesh_cli_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

void expect_closed_body(const std::string& path) {
  auto mesh = mimic::avatar::read_mesh(path);
  ASSERT_TRUE(mesh) << mesh.error().what();
  const auto t = mimic::avatar::analyze_topology(*mesh);
  EXPECT_TRUE(mimic::avatar::is_closed_oriented_manifold(t)) << path;
  EXPECT_GT(t.signed_volume, 0.04) << path;
  EXPECT_EQ(mesh->parts.size(), 16u) << path;
}

TEST(MeshCli, WritesEachFormatFromABvhFrame) {
  for (const char* ext : {"obj", "ply", "glb"}) {
    const std::string out = temp(std::string("07_01.") + ext);
    const Outcome r =
        run_mimic("mesh --bvh '" + mimic::test::clip_path("07_01") + "' --frame 120 --method full --out '" + out + "'");
    ASSERT_EQ(r.status, 0) << r.output;
    for (const char* stage : {"body", "skin", "pose", "contours", "B-spline", "stitch", "wrote"})
      EXPECT_NE(r.output.find(stage), std::string::npos) << stage << "\n" << r.output;
    EXPECT_NE(r.output.find("closed oriented manifold"), std::string::npos) << r.output;
    expect_closed_body(out);
    std::filesystem::remove(out);
  }
}

TEST(MeshCli, BuiltInMotionsAndRealtimeMode) {
  const std::string out = temp("walk.glb");
  Outcome r = run_mimic("mesh --motion walk --time 0.37 --method full --subdivision 0 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  expect_closed_body(out);
  r = run_mimic("mesh --motion idle --time 3 --method full --subdivision 2 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  expect_closed_body(out);
  // Without --method: the realtime skin, the default of every command (run, view, export).
  r = run_mimic("mesh --motion walk --time 0.4 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("frame     realtime"), std::string::npos) << r.output;
  expect_closed_body(out);
  std::filesystem::remove(out);
}

// --set bends joints of whatever pose was asked for (as `mimic view --set` does): the left knee
// bent to 149° lifts the left foot behind the body and leaves the right foot where it was.
TEST(MeshCli, SetBendsJointsOfTheChosenPose) {
  const std::string straight = temp("straight.obj"), bent = temp("bent.obj");
  Outcome r = run_mimic("mesh --pose zero --out '" + straight + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  r = run_mimic("mesh --pose zero --set l_knee_flexion=2.6 --out '" + bent + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("l_knee_flexion=2.6"), std::string::npos) << r.output;
  expect_closed_body(bent);
  auto a = mimic::avatar::read_mesh(straight), b = mimic::avatar::read_mesh(bent);
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->positions.size(), b->positions.size());
  auto lowest = [](const mimic::avatar::Mesh& m, const std::string& part) {
    float y = 1e9f;
    for (const auto& p : m.parts)
      if (p.name == part)
        for (uint32_t t = p.first_triangle; t < p.first_triangle + p.triangle_count; ++t)
          for (int k = 0; k < 3; ++k) y = std::min(y, m.positions[m.indices[3 * t + k]].y);
    return y;
  };
  EXPECT_GT(lowest(*b, "left_foot") - lowest(*a, "left_foot"), 0.3f);
  EXPECT_NEAR(lowest(*b, "right_foot"), lowest(*a, "right_foot"), 1e-6f);
  r = run_mimic("mesh --pose zero --set l_knee_flexion=bent --out /tmp/x.obj");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("'bent' is not a number"), std::string::npos) << r.output;
  for (const char* value : {"nan", "inf", "1.2x"}) {
    r = run_mimic(std::string("mesh --pose zero --set l_knee_flexion=") + value + " --out /tmp/x.obj");
    EXPECT_EQ(r.status, 2) << value << ": " << r.output;
    EXPECT_NE(r.output.find("is not a number"), std::string::npos) << r.output;
  }
  r = run_mimic("mesh --pose zero --set l_tail_wag=1 --out /tmp/x.obj");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("no DOF 'l_tail_wag'"), std::string::npos) << r.output;
  std::filesystem::remove(straight);
  std::filesystem::remove(bent);
}

// The realtime method at every LOD from a clip frame: closed, 16 parts, fewer triangles as the
// LOD coarsens; and the full method at a coarse LOD.
TEST(MeshCli, RealtimeMethodAtEveryLod) {
  const std::string out = temp("rt.ply");
  size_t previous = SIZE_MAX;
  for (int lod = 0; lod < 4; ++lod) {
    const Outcome r =
        run_mimic("mesh --bvh '" + mimic::test::clip_path("02_05") + "' --frame 200 --method realtime --lod " +
                  std::to_string(lod) + " --out '" + out + "'");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("realtime"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("rays"), std::string::npos) << "no ray per frame\n" << r.output;
    expect_closed_body(out);
    auto mesh = mimic::avatar::read_mesh(out);
    ASSERT_TRUE(mesh);
    EXPECT_LT(mesh->triangle_count(), previous);
    previous = mesh->triangle_count();
  }
  const Outcome r = run_mimic("mesh --motion walk --time 0.2 --method full --lod 2 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  expect_closed_body(out);
  std::filesystem::remove(out);
}

// --lod PIECE=N,...: each piece at its own LOD, both methods; the envelope stays closed and a
// coarser piece gives fewer triangles than the whole body at the finer LOD.
TEST(MeshCli, PiecesAtTheirOwnLods) {
  const std::string out = temp("pieces.obj");
  Outcome r = run_mimic("mesh --pose zero --lod 0 --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  auto whole = mimic::avatar::read_mesh(out);
  ASSERT_TRUE(whole);
  for (const char* method : {"full", "realtime"}) {
    r = run_mimic("mesh --bvh '" + mimic::test::clip_path("02_05") + "' --frame 200 --method " + method +
                  " --lod torso=0,neck=1,arms=3,legs=2 --uv --out '" + out + "'");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("lod       torso=0,neck=1,arms=3,legs=2,rigid=0"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("closed oriented manifold"), std::string::npos) << r.output;
    auto mesh = mimic::avatar::read_mesh(out);
    ASSERT_TRUE(mesh);
    EXPECT_EQ(mesh->parts.size(), 16u);
    EXPECT_LT(mesh->triangle_count(), whole->triangle_count() * 3 / 4) << method;
    EXPECT_TRUE(mimic::avatar::is_closed_oriented_manifold(
        mimic::avatar::analyze_topology(mimic::avatar::weld_by_position(*mesh, 1e-6f))))
        << method << ": closed once the UV seams are welded";
  }
  r = run_mimic("mesh --pose zero --lod arms=3,hands=1 --out '" + out + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("unknown skin piece 'hands'"), std::string::npos) << r.output;
  std::filesystem::remove(out);
}

// --uv: texture coordinates per part, seams split, one material per part in glTF.
TEST(MeshCli, UvWritesPerPartTextureCoordinates) {
  for (const char* method : {"realtime", "full"}) {
    const std::string out = temp(std::string("uv_") + method + ".glb");
    const Outcome r =
        run_mimic("mesh --motion walk --time 0.5 --uv --method " + std::string(method) + " --out '" + out + "'");
    ASSERT_EQ(r.status, 0) << r.output;
    auto mesh = mimic::avatar::read_mesh(out);
    ASSERT_TRUE(mesh) << mesh.error().what();
    EXPECT_EQ(mesh->uvs.size(), mesh->positions.size()) << method;
    EXPECT_EQ(mesh->parts.size(), 16u);
    auto bytes = mimic::avatar::encode_glb(*mesh);
    ASSERT_TRUE(bytes);
    EXPECT_NE(bytes->find("\"materials\""), std::string::npos);
    std::filesystem::remove(out);
  }
}

TEST(MeshCli, BadRequestsGetClearErrors) {
  Outcome m = run_mimic("mesh --pose zero --method fast --out /tmp/x.obj");
  EXPECT_EQ(m.status, 2);
  EXPECT_NE(m.output.find("full or realtime"), std::string::npos) << m.output;
  m = run_mimic("mesh --pose zero --lod 4 --out /tmp/x.obj");
  EXPECT_EQ(m.status, 2);
  EXPECT_NE(m.output.find("--lod"), std::string::npos) << m.output;
  m = run_mimic("mesh --pose zero --method realtime --subdivision 2 --out /tmp/x.obj");
  EXPECT_EQ(m.status, 2);
  Outcome r = run_mimic("mesh --bvh '" + mimic::test::clip_path("09_11") + "' --frame 166 --out /tmp/x.obj");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("frames 0..165"), std::string::npos) << r.output;
  r = run_mimic("mesh --motion moonwalk --out /tmp/x.obj");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("moonwalk"), std::string::npos) << r.output;
  r = run_mimic("mesh --pose zero --out /tmp/x.stl");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find(".stl"), std::string::npos) << r.output;
  r = run_mimic("mesh --pose zero");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
  r = run_mimic("mesh --body /nonexistent/body.json --pose zero --out /tmp/x.obj");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("/nonexistent/body.json"), std::string::npos) << r.output;
  // Numbers that parse but mean nothing are usage errors too, named by their option.
  for (const char* time : {"nan", "inf", "1e9", "-1"}) {
    r = run_mimic(std::string("mesh --motion walk --time ") + time + " --out /tmp/x.obj");
    EXPECT_EQ(r.status, 2) << time << ": " << r.output;
    EXPECT_NE(r.output.find("--time"), std::string::npos) << r.output;
  }
  r = run_mimic("mesh --pose zero --lod 7 --out /tmp/x.obj");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.find("LOD: LOD"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0..3"), std::string::npos) << r.output;
  // A folder that does not exist: the error names the path given, not a temporary file.
  r = run_mimic("mesh --pose zero --lod 3 --out /nonexistent-mimic-dir/x.obj");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("/nonexistent-mimic-dir/x.obj:"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find(".tmp"), std::string::npos) << r.output;
  r = run_mimic("mesh --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("--subdivision"), std::string::npos);
}

TEST(CompareCli, DefaultBodyMatchesTheReferenceWithinTenPercent) {
  const Outcome r = run_mimic("compare --json --check");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["pass"], true) << r.output;
  std::vector<std::string> keys;
  for (const auto& row : j["rows"]) keys.push_back(row["key"].get<std::string>());
  for (const char* k :
       {"height", "chest_girth", "waist_girth", "hip_girth", "thigh_girth", "calf_girth", "upper_arm_girth"})
    EXPECT_NE(std::find(keys.begin(), keys.end(), k), keys.end()) << k << "\n" << r.output;
}

}  // namespace

}  // namespace mesh_cli_test
