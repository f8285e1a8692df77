// Sensor rig and log codec throughput: samples per second for the built-in walk with each
// layout, log encoding and decoding of a one-minute, 11-sensor session.
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>

#include "mimic/rig/motion.h"
#include "mimic/sim/log.h"
#include "mimic/sim/sensor_rig.h"

namespace {

using namespace mimic;

std::shared_ptr<const rig::Motion> walk() {
  static auto skeleton = rig::Skeleton::build(rig::default_skeleton_desc()).value();
  static std::shared_ptr<const rig::Motion> motion(rig::make_builtin_motion("walk", skeleton).value());
  return motion;
}

sim::SensorRig make_rig(const char* layout) {
  sim::RigConfig c;
  c.sensors = sim::make_layout(layout, walk()->skeleton()).value();
  c.position_noise_mm = 1;
  c.orientation_noise_deg = 0.5;
  c.bias_walk_mm_per_sqrt_s = 0.2;
  c.dropout_probability = 0.01;
  c.seed = 1;
  return sim::SensorRig::create(walk(), c).value();
}

void BM_RigStep(benchmark::State& state, const char* layout) {
  auto rig = make_rig(layout);
  std::vector<devices::SensorSample> out(static_cast<size_t>(rig.sensor_count()));
  for (auto _ : state) {
    rig.step(out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * rig.sensor_count());
  state.SetLabel("items = samples");
}
BENCHMARK_CAPTURE(BM_RigStep, layout_3, "3");
BENCHMARK_CAPTURE(BM_RigStep, layout_11, "11");
BENCHMARK_CAPTURE(BM_RigStep, layout_all, "all");

std::vector<uint8_t> minute_log() {
  auto rig = make_rig("11");
  sim::LogHeader h;
  h.source = "sim:walk?sensors=11";
  std::vector<uint8_t> bytes;
  sim::encode_log_prefix(h, bytes);
  std::vector<devices::SensorSample> out(11);
  for (int k = 0; k < 6000; ++k) {
    rig.step(out);
    for (const auto& s : out) sim::encode_sample_record(s, bytes);
  }
  sim::encode_end_record(66000, bytes);
  return bytes;
}

void BM_LogEncodeSample(benchmark::State& state) {
  devices::SensorSample s;
  std::vector<uint8_t> buf;
  buf.reserve(1 << 20);
  for (auto _ : state) {
    if (buf.size() > (1 << 20) - 64) buf.clear();
    sim::encode_sample_record(s, buf);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_LogEncodeSample);

void BM_LogDecodeMinute(benchmark::State& state) {
  const auto bytes = minute_log();
  for (auto _ : state) {
    auto log = sim::decode_log(bytes);
    benchmark::DoNotOptimize(log->samples.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * 66000);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes.size()));
}
BENCHMARK(BM_LogDecodeMinute)->Unit(benchmark::kMillisecond);

}  // namespace
