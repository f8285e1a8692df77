// Scene protocol and server benchmarks: codec throughput, bytes per avatar-frame against VMC and
// raw floats, loopback latency, and subscriber fan-out at 90 Hz.
#include <benchmark/benchmark.h>

#include <random>

#include "mimic/net/frame_codec.h"
#include "mimic/net/loopback_bench.h"
#include "mimic/net/vmc.h"

namespace {

using namespace mimic;

const rig::Skeleton& skeleton() {
  static const rig::Skeleton s = *rig::Skeleton::build(rig::default_skeleton_desc());
  return s;
}

rig::Pose walk_like_pose() {
  rig::Pose p = skeleton().rest_pose();
  std::mt19937_64 rng(1);
  for (auto& a : p.dof_rad) a = float(int(rng() % 2000) - 1000) * 1e-3f;
  p.root_position_m = {0.1f, 0.93f, 1.7f};
  return p;
}

void BM_EncodePose(benchmark::State& state) {
  const rig::Pose p = walk_like_pose();
  std::vector<uint8_t> out(net::kMaxDatagramBytes);
  uint32_t seq = 0;
  size_t n = 0;
  for (auto _ : state) {
    n = net::encode_pose({1, 0, ++seq, 0}, p, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["bytes_per_frame"] = double(n);
}
BENCHMARK(BM_EncodePose);

void BM_DecodePose(benchmark::State& state) {
  const rig::Pose p = walk_like_pose();
  std::vector<uint8_t> out(net::kMaxDatagramBytes);
  out.resize(net::encode_pose({1, 0, 1, 0}, p, out));
  net::PoseHeader h;
  rig::Pose d = skeleton().rest_pose();
  for (auto _ : state) {
    benchmark::DoNotOptimize(net::decode_pose(out, h, d));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DecodePose);

// The same pose as a Mimic pose frame, a VMC bundle, and raw floats (root xyz + quaternion +
// one f32 per DOF, with the same 24 bytes of header/sequence/time as a pose frame).
void BM_BytesPerAvatarFrame(benchmark::State& state) {
  const rig::Pose p = walk_like_pose();
  net::VmcEncoder vmc(skeleton());
  std::vector<uint8_t> bundle, frame(net::kMaxDatagramBytes);
  size_t mimic_bytes = 0;
  for (auto _ : state) {
    mimic_bytes = net::encode_pose({1, 0, 1, 0}, p, frame);
    vmc.encode(p, 1.0, bundle);
    benchmark::DoNotOptimize(bundle.data());
  }
  const double raw = 24.0 + 4.0 * (3 + 4 + double(p.dof_rad.size()));
  state.counters["mimic_bytes"] = double(mimic_bytes);
  state.counters["vmc_bytes"] = double(bundle.size());
  state.counters["raw_float_bytes"] = raw;
  state.counters["vmc_over_mimic"] = double(bundle.size()) / double(mimic_bytes);
  state.counters["raw_over_mimic"] = raw / double(mimic_bytes);
}
BENCHMARK(BM_BytesPerAvatarFrame);

// arg: 1 = pose frames as UDP datagrams.
void BM_LoopbackLatency(benchmark::State& state) {
  for (auto _ : state) {
    auto r = net::measure_loopback_latency(2000, 52, state.range(0) != 0);
    if (!r) {
      state.SkipWithError(r.error().what().c_str());
      return;
    }
    state.counters["p50_us"] = r->p50_us;
    state.counters["p99_us"] = r->p99_us;
    state.counters["max_us"] = r->max_us;
  }
}
BENCHMARK(BM_LoopbackLatency)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);

// args: subscribers, avatars. 90 Hz for 2 s.
void BM_Fanout90Hz(benchmark::State& state) {
  for (auto _ : state) {
    auto r = net::measure_fanout(int(state.range(0)), int(state.range(1)), 90.0, 2.0);
    if (!r) {
      state.SkipWithError(r.error().what().c_str());
      return;
    }
    state.counters["streams"] = double(r->subscribers * r->avatars);
    state.counters["received"] = double(r->frames_received);
    state.counters["expected"] = double(r->frames_expected);
    state.counters["dropped"] = double(r->frames_dropped);
    state.counters["lost"] = double(r->lost);
    state.counters["tick_p99_us"] = r->tick_p99_us;
    state.counters["rate_hz"] = r->achieved_rate_hz;
    state.counters["kept_up"] = r->kept_up ? 1 : 0;
  }
}
BENCHMARK(BM_Fanout90Hz)
    ->Args({10, 1})
    ->Args({100, 4})
    ->Args({250, 4})
    ->Args({1000, 1})
    ->Args({500, 4})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
