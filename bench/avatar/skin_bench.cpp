// Per-stage cost of one avatar frame at the default resolution (the full method), the realtime
// method at every LOD, and the baseline skinnings (LBS, DQS, CoR) deforming the same mesh (same
// vertex count) for the ratio.
#include <benchmark/benchmark.h>

#include <random>

#include "mimic/avatar/baselines/baseline_skinner.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar {
namespace {

std::vector<rig::Pose> poses(const rig::Skeleton& s, int n) {
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<rig::Pose> out;
  for (int k = 0; k < n; ++k) {
    rig::Pose p = s.rest_pose();
    for (int i = 0; i < s.dof_count(); ++i) {
      const rig::Dof& d = s.dof(i);
      p.dof_rad[i] = 0.5f * (d.min_rad + u(rng) * (d.max_rad - d.min_rad));
    }
    p.root_position_m = {0, 0.9f, 0};
    out.push_back(std::move(p));
  }
  return out;
}

ImplicitSkin make(int subdivision, bool normals = false) {
  SkinOptions o;
  o.subdivision = subdivision;
  o.normals = normals;
  return std::move(*ImplicitSkin::create(default_body_model(), o));
}

void set_counters(benchmark::State& state, const ImplicitSkin& skin) {
  state.counters["vertices"] = static_cast<double>(skin.mesh().positions.size());
  state.counters["rays"] = skin.stats().rays;
  state.SetItemsProcessed(state.iterations());
}

void BM_Frame(benchmark::State& state) {
  ImplicitSkin skin = make(static_cast<int>(state.range(0)));
  const auto ps = poses(skin.skeleton(), 16);
  size_t i = 0;
  for (auto _ : state) {
    skin.evaluate(ps[i++ % ps.size()]);
    benchmark::DoNotOptimize(skin.mesh().positions.data());
  }
  set_counters(state, skin);
}
BENCHMARK(BM_Frame)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// The same frame plus area-weighted vertex normals (what a renderer or a mesh file needs).
void BM_FrameWithNormals(benchmark::State& state) {
  ImplicitSkin skin = make(static_cast<int>(state.range(0)), true);
  const auto ps = poses(skin.skeleton(), 16);
  size_t i = 0;
  for (auto _ : state) {
    skin.evaluate(ps[i++ % ps.size()]);
    benchmark::DoNotOptimize(skin.mesh().normals.data());
  }
  set_counters(state, skin);
}
BENCHMARK(BM_FrameWithNormals)->Arg(1)->Unit(benchmark::kMicrosecond);

enum Stage { kFk, kDeform, kContours, kBspline, kStitch };

void BM_Stage(benchmark::State& state) {
  ImplicitSkin skin = make(1);
  const auto ps = poses(skin.skeleton(), 16);
  const auto stage = static_cast<Stage>(state.range(0));
  size_t i = 0;
  for (auto _ : state) {
    const rig::Pose& p = ps[i++ % ps.size()];
    state.PauseTiming();
    skin.stage_fk(p);
    if (stage > kDeform) skin.stage_deform(p);
    if (stage > kContours) skin.stage_contours();
    if (stage > kBspline) skin.stage_bspline();
    state.ResumeTiming();
    switch (stage) {
      case kFk: skin.stage_fk(p); break;
      case kDeform: skin.stage_deform(p); break;
      case kContours: skin.stage_contours(); break;
      case kBspline: skin.stage_bspline(); break;
      case kStitch: skin.stage_stitch(); break;
    }
  }
  set_counters(state, skin);
}
BENCHMARK(BM_Stage)->ArgName("fk0_deform1_contours2_bspline3_stitch4")->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);

// The baseline skinnings of the same mesh (avatar/baselines/): FK, skinning transforms and the
// vertices per iteration, as a frame would run them. Per-vertex figures: baselines_bench.cpp.
void BM_BaselineSkinning(benchmark::State& state) {
  ImplicitSkin skin = make(1);
  const rig::Skeleton& s = skin.skeleton();
  skin.evaluate(s.zero_pose());
  auto skinner = baselines::bind_to_links(s, s.zero_pose(), skin.mesh());
  const auto method = static_cast<baselines::SkinningMethod>(state.range(0));
  std::vector<rig::RigidTransform> w(s.joint_count());
  std::vector<glm::vec3> out(skinner->vertex_count());
  const auto ps = poses(s, 16);
  size_t i = 0;
  for (auto _ : state) {
    rig::forward_kinematics(s, ps[i++ % ps.size()], w);
    skinner->set_pose(w);
    skinner->deform(method, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["vertices"] = static_cast<double>(skinner->vertex_count());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BaselineSkinning)->ArgName("lbs0_dqs1_cor2")->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);

// The realtime method (realtime_skin.h) at LOD range(0), muscles on when range(1) is 1.
void BM_Realtime(benchmark::State& state) {
  RealtimeOptions o;
  o.lod = static_cast<int>(state.range(0));
  auto body = RealtimeBody::create(default_body_model(), o);
  if (!body) {
    state.SkipWithError(body.error().what().c_str());
    return;
  }
  RealtimeSkin skin(*body);
  std::vector<glm::vec3> out((*body)->vertex_count());
  const auto ps = poses((*body)->skeleton(), 16);
  const bool muscles = state.range(1) != 0;
  size_t i = 0;
  for (auto _ : state) {
    skin.evaluate(ps[i++ % ps.size()], out, {}, muscles);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["vertices"] = static_cast<double>(out.size());
  state.SetItemsProcessed(state.iterations());
  // What bounds it (docs/skin.md): the point loops' traffic and arithmetic per frame, and the
  // rates they run at (bytes and flops per second of the whole frame).
  const RealtimeBody::FrameWork w = (*body)->work_per_frame(muscles);
  state.counters["bytes_per_vertex"] = (w.bytes_read + w.bytes_written) / static_cast<double>(out.size());
  state.counters["flops_per_vertex"] = w.flops / static_cast<double>(out.size());
  state.counters["bytes"] =
      benchmark::Counter(w.bytes_read + w.bytes_written, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["flops"] = benchmark::Counter(w.flops, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["vectorised"] = RealtimeSkin::vectorised_kernel() ? 1 : 0;
}
BENCHMARK(BM_Realtime)
    ->ArgNames({"lod", "muscles"})
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

// The realtime frame with its vertex normals (what a renderer or the browser page asks for) at
// LOD range(0).
void BM_RealtimeWithNormals(benchmark::State& state) {
  RealtimeOptions o;
  o.lod = static_cast<int>(state.range(0));
  auto body = RealtimeBody::create(default_body_model(), o);
  if (!body) {
    state.SkipWithError(body.error().what().c_str());
    return;
  }
  RealtimeSkin skin(*body);
  std::vector<glm::vec3> out((*body)->vertex_count()), normals(out.size());
  const auto ps = poses((*body)->skeleton(), 16);
  size_t i = 0;
  for (auto _ : state) {
    skin.evaluate(ps[i++ % ps.size()], out, normals, true);
    benchmark::DoNotOptimize(normals.data());
  }
  state.counters["normals_us"] = skin.timings().normals_us;
  state.counters["vertices"] = static_cast<double>(out.size());
}
BENCHMARK(BM_RealtimeWithNormals)->ArgName("lod")->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);

// The same with the scalar reference loops (what the eight-wide kernels gain).
void BM_RealtimeScalar(benchmark::State& state) {
  auto body = RealtimeBody::create(default_body_model(), RealtimeOptions{});
  if (!body) {
    state.SkipWithError(body.error().what().c_str());
    return;
  }
  RealtimeSkin skin(*body);
  skin.use_scalar_reference(true);
  std::vector<glm::vec3> out((*body)->vertex_count());
  const auto ps = poses((*body)->skeleton(), 16);
  size_t i = 0;
  for (auto _ : state) {
    skin.evaluate(ps[i++ % ps.size()], out, {}, true);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["vertices"] = static_cast<double>(out.size());
}
BENCHMARK(BM_RealtimeScalar)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace mimic::avatar
