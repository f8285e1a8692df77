// Per-stage cost of one avatar frame at the default resolution, and a linear blend skinning
// baseline deforming the same mesh (same vertex count) for the ratio.
#include <benchmark/benchmark.h>

#include <random>

#include "mimic/avatar/skin.h"

namespace mimic::avatar {
namespace {

std::vector<Pose> poses(const Skeleton& s, int n) {
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Pose> out;
  for (int k = 0; k < n; ++k) {
    Pose p = s.rest_pose();
    for (int i = 0; i < s.dof_count(); ++i) {
      const Dof& d = s.dof(i);
      p.dof_rad[i] = 0.5f * (d.min_rad + u(rng) * (d.max_rad - d.min_rad));
    }
    p.root_position_m = {0, 0.9f, 0};
    out.push_back(std::move(p));
  }
  return out;
}

BodySkin make(int subdivision, bool normals = false) {
  SkinOptions o;
  o.subdivision = subdivision;
  o.normals = normals;
  return std::move(*BodySkin::create(default_body_model(), o));
}

void set_counters(benchmark::State& state, const BodySkin& skin) {
  state.counters["vertices"] = static_cast<double>(skin.mesh().positions.size());
  state.counters["rays"] = skin.stats().rays;
  state.SetItemsProcessed(state.iterations());
}

void BM_Frame(benchmark::State& state) {
  BodySkin skin = make(static_cast<int>(state.range(0)));
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
  BodySkin skin = make(static_cast<int>(state.range(0)), true);
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
  BodySkin skin = make(1);
  const auto ps = poses(skin.skeleton(), 16);
  const auto stage = static_cast<Stage>(state.range(0));
  size_t i = 0;
  for (auto _ : state) {
    const Pose& p = ps[i++ % ps.size()];
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

// Linear blend skinning of the same mesh: each vertex bound to its two nearest joints by
// inverse-distance weights in the rest posture; per frame v' = Σ w M v.
void BM_LinearBlendSkinningBaseline(benchmark::State& state) {
  BodySkin skin = make(1);
  const Skeleton& s = skin.skeleton();
  const std::vector<glm::vec3> rest = skin.mesh().positions;
  std::vector<RigidTransform> rest_w(s.joint_count()), w(s.joint_count());
  forward_kinematics(s, s.zero_pose(), rest_w);
  struct Bind {
    int j0, j1;
    float w0;
    glm::vec3 l0, l1;
  };
  std::vector<Bind> binds;
  for (const glm::vec3& v : rest) {
    int best[2] = {0, 0};
    float d[2] = {1e9f, 1e9f};
    for (int j = 0; j < s.joint_count(); ++j) {
      const glm::vec3 mid = rest_w[j].apply(0.5f * s.tip_m(j));
      const float dd = glm::distance(v, mid);
      if (dd < d[0]) {
        d[1] = d[0], best[1] = best[0];
        d[0] = dd, best[0] = j;
      } else if (dd < d[1]) {
        d[1] = dd, best[1] = j;
      }
    }
    const float w0 = d[1] / (d[0] + d[1]);
    binds.push_back({best[0], best[1], w0, rest_w[best[0]].inverse().apply(v), rest_w[best[1]].inverse().apply(v)});
  }
  std::vector<glm::vec3> out(rest.size()), nrm(rest.size());
  const auto ps = poses(s, 16);
  size_t i = 0;
  for (auto _ : state) {
    forward_kinematics(s, ps[i++ % ps.size()], w);
    for (size_t k = 0; k < binds.size(); ++k) {
      const Bind& b = binds[k];
      out[k] = b.w0 * w[b.j0].apply(b.l0) + (1.0f - b.w0) * w[b.j1].apply(b.l1);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["vertices"] = static_cast<double>(rest.size());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_LinearBlendSkinningBaseline)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace mimic::avatar
