// Per-vertex cost of the baseline skinning jobs (avatar/baselines/): a 10,000-vertex mesh of
// cylinders around a 32-joint chain, four influences per vertex of which two are non-zero near
// each joint (as a typical limb skin), joint transforms converted once per iteration. Items are
// vertices, so items/s gives the vertex rate and 1e9 / items_per_second the ns per vertex.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "mimic/avatar/baselines/cor_skinning.h"
#include "mimic/avatar/baselines/dual_quaternion_skinning.h"
#include "mimic/avatar/baselines/linear_blend_skinning.h"
#include "mimic/avatar/baselines/skin_weights.h"

namespace mimic::avatar::baselines {
namespace {

constexpr int kJoints = 32;
constexpr int kVertices = 10000;

struct Scene {
  std::vector<glm::vec3> positions, normals, centers;
  std::vector<uint16_t> joints;
  std::vector<float> weights;
  std::vector<SkinningMatrix> matrices;
  std::vector<DualQuat> dual_quats;
  std::vector<glm::quat> rotations;
  std::vector<glm::vec3> out_p, out_n;

  Scene() {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int v = 0; v < kVertices; ++v) {
      const float along = float(kJoints) * float(v) / float(kVertices);  // joint lengths of 1
      const int j = std::min(int(along), kJoints - 1);
      const float phi = 6.2831853f * u(rng);
      positions.push_back({along, 0.05f * std::cos(phi), 0.05f * std::sin(phi)});
      normals.push_back({0, std::cos(phi), std::sin(phi)});
      centers.push_back({along, 0, 0});
      const float f = along - float(j);
      const int k = f < 0.5f ? std::max(j - 1, 0) : std::min(j + 1, kJoints - 1);
      const float wk = 0.5f * std::max(0.0f, 1.0f - std::abs(f - 0.5f) * 2 / 0.3f);
      joints.insert(joints.end(), {uint16_t(j), uint16_t(k), 0, 0});
      weights.insert(weights.end(), {1 - wk, wk, 0, 0});
    }
    std::vector<rig::RigidTransform> w(kJoints), inv(kJoints);
    for (int j = 0; j < kJoints; ++j) {
      w[j] = {glm::normalize(glm::quat(1.0f, 0.1f * u(rng), 0.1f * u(rng), 0.1f * u(rng))), {u(rng), u(rng), u(rng)}};
    }
    matrices.resize(kJoints), dual_quats.resize(kJoints), rotations.resize(kJoints);
    skinning_transforms(w, inv, matrices, dual_quats, rotations);
    out_p.resize(kVertices), out_n.resize(kVertices);
  }
};

void finish(benchmark::State& state) {
  state.SetItemsProcessed(state.iterations() * kVertices);
  state.counters["ns_per_vertex"] = benchmark::Counter(
      double(kVertices), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

std::span<const glm::vec3> maybe_in(const std::vector<glm::vec3>& v, bool on) {
  return on ? std::span<const glm::vec3>(v) : std::span<const glm::vec3>{};
}
std::span<glm::vec3> maybe(std::vector<glm::vec3>& v, bool on) {
  return on ? std::span<glm::vec3>(v) : std::span<glm::vec3>{};
}

void BM_LinearBlendSkinning(benchmark::State& state) {
  Scene s;
  const bool normals = state.range(0) != 0;
  LinearBlendSkinningJob job{
      s.matrices, s.joints, s.weights, s.positions, maybe_in(s.normals, normals), s.out_p, maybe(s.out_n, normals)};
  for (auto _ : state) {
    job.Run();
    benchmark::DoNotOptimize(s.out_p.data());
    benchmark::ClobberMemory();
  }
  finish(state);
}
BENCHMARK(BM_LinearBlendSkinning)->ArgName("normals")->Arg(0)->Arg(1);

void BM_DualQuaternionSkinning(benchmark::State& state) {
  Scene s;
  const bool normals = state.range(0) != 0;
  DualQuaternionSkinningJob job{
      s.dual_quats, s.joints, s.weights, s.positions, maybe_in(s.normals, normals), s.out_p, maybe(s.out_n, normals)};
  for (auto _ : state) {
    job.Run();
    benchmark::DoNotOptimize(s.out_p.data());
    benchmark::ClobberMemory();
  }
  finish(state);
}
BENCHMARK(BM_DualQuaternionSkinning)->ArgName("normals")->Arg(0)->Arg(1);

void BM_CorSkinning(benchmark::State& state) {
  Scene s;
  const bool normals = state.range(0) != 0;
  CorSkinningJob job{s.matrices,
                     s.rotations,
                     s.joints,
                     s.weights,
                     s.centers,
                     s.positions,
                     maybe_in(s.normals, normals),
                     s.out_p,
                     maybe(s.out_n, normals)};
  for (auto _ : state) {
    job.Run();
    benchmark::DoNotOptimize(s.out_p.data());
    benchmark::ClobberMemory();
  }
  finish(state);
}
BENCHMARK(BM_CorSkinning)->ArgName("normals")->Arg(0)->Arg(1);

}  // namespace
}  // namespace mimic::avatar::baselines
