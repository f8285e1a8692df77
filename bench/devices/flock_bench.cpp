// Flock of Birds decoding cost: splitting a byte stream into records, and turning a record into
// a SensorSample in metres and Mimic's axes.
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "mimic/devices/flock_packet.h"

namespace fl = mimic::devices::flock;

namespace {

// A stream of `n` records of `layout`, four birds in group mode, random poses (fixed seed).
std::vector<uint8_t> make_stream(const fl::RecordLayout& layout, int n) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<uint8_t> bytes;
  for (int i = 0; i < n; ++i) {
    const glm::dquat q = glm::normalize(glm::dquat(u(rng), u(rng), u(rng), u(rng)));
    fl::Measurement m = fl::measurement_from_pose({u(rng) * 30, u(rng) * 30, u(rng) * 30}, glm::mat3_cast(q));
    m.address = static_cast<uint8_t>(1 + i % 4);
    const fl::RawRecord r = fl::to_raw(m, layout, fl::PositionRange::in36);
    std::vector<uint8_t> rec(layout.size());
    fl::encode_record(r, rec);
    bytes.insert(bytes.end(), rec.begin(), rec.end());
  }
  return bytes;
}

void BM_FlockStreamDecode(benchmark::State& state) {
  const auto format = static_cast<fl::Format>(state.range(0));
  const fl::RecordLayout layout{format, false, true};
  const int n = 4096;
  const auto bytes = make_stream(layout, n);
  fl::StreamDecoder decoder(layout);
  int64_t records = 0;
  for (auto _ : state) {
    decoder.feed(bytes, [&](const fl::RawRecord& r, size_t) { benchmark::DoNotOptimize(r.words[0]); });
    records += n;
  }
  state.SetItemsProcessed(records);
  state.SetBytesProcessed(records * static_cast<int64_t>(layout.size()));
  state.SetLabel(fl::format_name(format));
}
BENCHMARK(BM_FlockStreamDecode)->Arg(1)->Arg(4)->Arg(5)->Arg(8);

// Decode + scale + frame change + quaternion conversion: the whole per-record cost in the driver.
void BM_FlockRecordToSample(benchmark::State& state) {
  const auto format = static_cast<fl::Format>(state.range(0));
  const fl::RecordLayout layout{format, false, true};
  const int n = 1024;
  const auto bytes = make_stream(layout, n);
  fl::StreamDecoder decoder(layout);
  int64_t records = 0;
  for (auto _ : state) {
    decoder.feed(bytes, [&](const fl::RawRecord& r, size_t) {
      const mimic::devices::SensorSample s = fl::to_sample(fl::from_raw(r, fl::PositionRange::in36), layout);
      benchmark::DoNotOptimize(s);
    });
    records += n;
  }
  state.SetItemsProcessed(records);
  state.SetLabel(fl::format_name(format));
}
BENCHMARK(BM_FlockRecordToSample)->Arg(1)->Arg(4)->Arg(5)->Arg(8);

// The same stream with a fault every 10th record: the cost of resynchronising.
void BM_FlockStreamDecodeWithFaults(benchmark::State& state) {
  const fl::RecordLayout layout{fl::Format::position_quaternion, false, true};
  auto bytes = make_stream(layout, 4096);
  std::mt19937_64 rng(2);
  for (size_t i = layout.size() * 5; i + 20 < bytes.size(); i += layout.size() * 10) bytes[i + 3] |= 0x80;
  fl::StreamDecoder decoder(layout);
  int64_t records = 0;
  for (auto _ : state) {
    decoder.feed(bytes, [&](const fl::RawRecord& r, size_t) { benchmark::DoNotOptimize(r.words[0]); });
    records += 4096;
  }
  state.SetItemsProcessed(records);
  state.counters["resyncs_per_pass"] = static_cast<double>(decoder.resyncs()) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_FlockStreamDecodeWithFaults);

}  // namespace
