// BVH parsing, retargeting, joint-angle decomposition and procedural motion sampling.
#include <benchmark/benchmark.h>

#include <random>

#include "mimic/rig/bvh.h"
#include "mimic/rig/joint_angles.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/retarget.h"
#include "mimic/core/file.h"

namespace {

using namespace mimic;

const std::string& clip_text() {
  static const std::string text = [] {
    auto t = mimic::read_file(std::string(MIMIC_SHARED_DATA) + "/bvh/13_26.bvh");  // 2.3 MB, 3029 frames
    return t ? *t : std::string();
  }();
  return text;
}

void BM_ParseBvh(benchmark::State& state) {
  const std::string& text = clip_text();
  if (text.empty()) {
    state.SkipWithError("shared clip 13_26.bvh not found");
    return;
  }
  for (auto _ : state) {
    auto clip = rig::parse_bvh(text, "13_26.bvh");
    benchmark::DoNotOptimize(clip);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(text.size()));
}
BENCHMARK(BM_ParseBvh)->Unit(benchmark::kMillisecond);

void BM_RetargetFrames(benchmark::State& state) {
  auto clip = rig::parse_bvh(clip_text(), "13_26.bvh");
  if (!clip) {
    state.SkipWithError("shared clip 13_26.bvh not found");
    return;
  }
  for (auto _ : state) {
    auto r = rig::retarget_bvh(*clip);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * clip->frame_count);
}
BENCHMARK(BM_RetargetFrames)->Unit(benchmark::kMillisecond);

void BM_BvhForwardKinematics(benchmark::State& state) {
  auto clip = rig::parse_bvh(clip_text(), "13_26.bvh");
  if (!clip) {
    state.SkipWithError("shared clip 13_26.bvh not found");
    return;
  }
  std::vector<rig::RigidTransform> w(clip->joints.size());
  int f = 0;
  for (auto _ : state) {
    rig::bvh_forward_kinematics(*clip, f, w);
    benchmark::DoNotOptimize(w.data());
    f = (f + 1) % clip->frame_count;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BvhForwardKinematics);

void BM_EulerDecomposition(benchmark::State& state) {
  const glm::dvec3 axes[3] = {{0, -1, 0}, {0, 0, 1}, {-1, 0, 0}};
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<glm::dquat> q(256);
  for (auto& x : q) x = glm::normalize(glm::dquat(u(rng), u(rng), u(rng), u(rng)));
  double prev[3] = {0, 0, 0}, out[3];
  size_t i = 0;
  for (auto _ : state) {
    rig::dofs_from_rotation(axes, q[i++ & 255], prev, out);
    benchmark::DoNotOptimize(out);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EulerDecomposition);

void BM_BuiltinMotionSample(benchmark::State& state, const char* name) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  auto m = rig::make_builtin_motion(name, *s);
  rig::Pose p = s->zero_pose();
  double t = 0;
  for (auto _ : state) {
    (*m)->sample(t, p);
    benchmark::DoNotOptimize(p.dof_rad.data());
    t += 1.0 / 120;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_BuiltinMotionSample, idle, "idle");
BENCHMARK_CAPTURE(BM_BuiltinMotionSample, walk, "walk");

}  // namespace
