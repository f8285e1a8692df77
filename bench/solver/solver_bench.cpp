// Solver benchmarks: per-frame solve time for each sensor layout on a shared CMU clip, the IK
// building blocks, and the accuracy figures (MPJPE, MPJRE, end effectors, jitter) on every
// shared clip as counters. Sensors are synthesised by forward kinematics with 1 mm / 0.5° noise
// and straps askew by up to 20°, calibrated on the clip's frame-0 T-pose (tests/solver/clip_eval.h).
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "../../tests/solver/clip_eval.h"
#include "mimic/rig/bvh.h"
#include "mimic/solver/filters.h"
#include "mimic/solver/two_bone_ik.h"

namespace {

using namespace mimic;

const char* kClips[] = {"02_04", "02_05", "02_06", "05_02", "06_04", "07_01", "09_11", "13_26"};
const char* kLayouts[] = {"3", "6", "11", "all"};

const rig::RetargetedClip* clip(const std::string& id) {
  static std::map<std::string, std::unique_ptr<rig::RetargetedClip>> cache;
  auto it = cache.find(id);
  if (it != cache.end()) return it->second.get();
  auto bvh = rig::load_bvh(std::string(MIMIC_SHARED_DATA) + "/bvh/" + id + ".bvh");
  if (!bvh) return nullptr;
  auto r = rig::retarget_bvh(*bvh);
  if (!r) return nullptr;
  return (cache[id] = std::make_unique<rig::RetargetedClip>(std::move(*r))).get();
}

// 07_01 worn by a layout's sensors (straps askew by up to 20°, 1 mm / 0.5° noise), calibrated
// on its frame-0 T-pose, with the sensor samples of every later frame.
struct WornClip {
  solver::Calibration calibration;
  std::vector<solver::SensorMount> mounts;
  std::vector<std::vector<devices::SensorSample>> frames;
};

std::optional<WornClip> wear_07_01(const char* layout_name) {
  const auto* c = clip("07_01");
  if (!c) return std::nullopt;
  auto layout = *solver::standard_layout(layout_name, c->skeleton);
  WornClip w;
  w.mounts = solver::testing::mounts_for(layout, glm::radians(20.0f), 1);
  std::mt19937_64 rng(1);
  std::vector<devices::SensorSample> capture, tick;
  for (int k = 0; k < 100; ++k) {
    solver::testing::sense(c->skeleton, c->poses[0], w.mounts, tick, &rng, 0.001f, glm::radians(0.5f), 0.01 * k);
    capture.insert(capture.end(), tick.begin(), tick.end());
  }
  w.calibration = *solver::calibrate(solver::tracking_skeleton_desc(), layout, capture);
  for (size_t f = 1; f < c->poses.size(); ++f) {
    solver::testing::sense(c->skeleton, c->poses[f], w.mounts, tick, &rng, 0.001f, glm::radians(0.5f),
                           static_cast<double>(f) * c->frame_time_s);
    w.frames.push_back(tick);
  }
  return w;
}

// Filtering + solving one frame of 07_01 (walk), frames cycled, warm-started as in a live run.
void BM_SolveFrame(benchmark::State& state) {
  const char* layout_name = kLayouts[state.range(0)];
  auto worn = wear_07_01(layout_name);
  if (!worn) {
    state.SkipWithError("shared clip 07_01 not found (set MIMIC_SHARED_DATA)");
    return;
  }
  auto model = *solver::make_solver_model(worn->calibration);
  const auto& mounts = worn->mounts;
  const auto& frames = worn->frames;
  solver::SolverContext ctx(model);
  solver::SensorFilterBank filters(static_cast<int>(mounts.size()));
  rig::Pose pose = model.skeleton().zero_pose();
  size_t f = 0;
  double ls_iterations = 0;
  std::vector<devices::SensorSample> work(mounts.size());
  for (auto _ : state) {
    std::copy(frames[f].begin(), frames[f].end(), work.begin());
    filters.process(work);
    solver::SolveJob job{&model, work, &ctx, &pose};
    job.Run();
    ls_iterations += job.ls_iterations;
    benchmark::DoNotOptimize(pose.dof_rad.data());
    if (++f == frames.size()) {
      f = 0;
      filters.reset();  // the clip restarts: no outlier from the jump back
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["ls_iterations"] = ls_iterations / static_cast<double>(state.iterations());
  state.SetLabel(std::string(layout_name) + " sensors");
}
BENCHMARK(BM_SolveFrame)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);

// The input filters alone on one frame of 07_01 (layout 11), with (1) and without (0) the
// fixed-lag smoother after the One Euro stage: what the smoother costs per frame.
void BM_FilterFrame(benchmark::State& state) {
  auto worn = wear_07_01("11");
  if (!worn) {
    state.SkipWithError("shared clip 07_01 not found (set MIMIC_SHARED_DATA)");
    return;
  }
  solver::SensorFilterConfig config;
  if (state.range(0) == 0) config.position_smoother.window = config.rotation_smoother.window = 1;
  solver::SensorFilterBank filters(static_cast<int>(worn->mounts.size()), config);
  const auto& frames = worn->frames;
  std::vector<devices::SensorSample> work(worn->mounts.size());
  size_t f = 0;
  for (auto _ : state) {
    std::copy(frames[f].begin(), frames[f].end(), work.begin());
    filters.process(work);
    benchmark::DoNotOptimize(work.data());
    if (++f == frames.size()) {
      f = 0;
      filters.reset();
    }
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(state.range(0) ? "11 sensors, smoothed" : "11 sensors, One Euro only");
}
BENCHMARK(BM_FilterFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The functional calibration's per-tick cost (raw samples into the limb and joint-centre
// estimators; the in-place limb refit twice a second included), 07_01, layouts 11 and all.
void BM_RefinerAdd(benchmark::State& state) {
  const char* layout_name = kLayouts[state.range(0)];
  auto worn = wear_07_01(layout_name);
  if (!worn) {
    state.SkipWithError("shared clip 07_01 not found (set MIMIC_SHARED_DATA)");
    return;
  }
  const auto& cal = worn->calibration;
  const auto& frames = worn->frames;
  auto model = *solver::make_solver_model(cal);
  solver::ModelRefiner refiner(cal, model, 1e9);  // no rebuild falls due while timing
  size_t f = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(refiner.add(frames[f], model));
    if (++f == frames.size()) f = 0;
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(std::string(layout_name) + " sensors, " + std::to_string(refiner.centres().pair_count()) +
                 " joint pairs, " + std::to_string(refiner.limbs().observable_count()) + " limbs");
}
BENCHMARK(BM_RefinerAdd)->Arg(2)->Arg(3)->Unit(benchmark::kMicrosecond);

void BM_TwoBoneIk(benchmark::State& state) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<float> u(-0.4f, 0.4f);
  std::vector<glm::vec3> targets(256);
  for (auto& t : targets) t = {u(rng), u(rng), u(rng)};
  size_t i = 0;
  for (auto _ : state) {
    solver::TwoBoneIkJob job;
    job.upper_m = 0.3f;
    job.lower_m = 0.25f;
    job.target_m = targets[i++ & 255];
    job.pole_dir = {0, -1, -0.3f};
    job.Run();
    benchmark::DoNotOptimize(job.mid_m);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TwoBoneIk);

// Accuracy on every shared clip (counters; one pass each). Slow: run with
// --benchmark_filter=Accuracy.
void BM_Accuracy(benchmark::State& state) {
  const char* layout_name = kLayouts[state.range(1)];
  const char* id = kClips[state.range(0)];
  const auto* c = clip(id);
  if (!c) {
    state.SkipWithError("shared clip not found (set MIMIC_SHARED_DATA)");
    return;
  }
  solver::testing::ClipEvalConfig cfg;
  cfg.layout = layout_name;
  solver::testing::ClipEval r;
  for (auto _ : state) r = solver::testing::evaluate_clip(*c, cfg);
  if (!r.error.empty()) {
    state.SkipWithError(r.error.c_str());
    return;
  }
  state.counters["mpjpe_cm"] = r.report.mpjpe_cm;
  state.counters["mpjre_deg"] = r.report.mpjre_deg;
  state.counters["ee_mm"] = r.report.end_effector_mm;
  state.counters["jitter_mm"] = r.report.jitter_mm;
  state.counters["jitter_truth_mm"] = r.report.jitter_truth_mm;
  state.counters["solve_us_p50"] = r.report.solve_us_p50;
  state.counters["solve_us_p99"] = r.report.solve_us_p99;
  state.counters["frames"] = r.report.frames;
  state.SetLabel(std::string(id) + " " + layout_name + " sensors");
}
BENCHMARK(BM_Accuracy)
    ->ArgsProduct({benchmark::CreateDenseRange(0, 7, 1), benchmark::CreateDenseRange(0, 3, 1)})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
