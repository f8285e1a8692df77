// Decoding throughput of the 6-DOF input codecs: a fixed, seeded byte stream framed and decoded
// per iteration. Items are packets; bytes/s is the wire rate the decoder could keep up with
// (the devices send about 1 kB/s).
#include <benchmark/benchmark.h>

#include <array>
#include <random>
#include <vector>

#include "mimic/devices/hid_packet.h"
#include "mimic/devices/magellan_packet.h"
#include "mimic/devices/spaceball_packet.h"

namespace sb = mimic::devices::spaceball;
namespace mg = mimic::devices::magellan;
namespace hid = mimic::devices::hid;

namespace {

constexpr int kPackets = 1000;

std::vector<uint8_t> spaceball_stream() {
  std::mt19937_64 rng(1);
  std::vector<uint8_t> out;
  std::array<uint8_t, 31> wire{};
  for (int i = 0; i < kPackets; ++i) {
    sb::Axes a;
    for (auto& v : a) v = static_cast<int16_t>(rng());
    const size_t n = sb::encode_packet(sb::displacement_body(480, a), wire);
    out.insert(out.end(), wire.begin(), wire.begin() + static_cast<long>(n));
  }
  return out;
}

std::vector<uint8_t> magellan_stream() {
  std::mt19937_64 rng(2);
  std::vector<uint8_t> out;
  for (int i = 0; i < kPackets; ++i) {
    mg::Axes a;
    for (auto& v : a) v = static_cast<int16_t>(rng());
    const auto d = mg::data_packet(a);
    out.insert(out.end(), d.begin(), d.end());
  }
  return out;
}

void BM_SpaceballFrameAndDecode(benchmark::State& state) {
  const auto bytes = spaceball_stream();
  sb::Framer f;
  int64_t sum = 0;
  for (auto _ : state) {
    for (uint8_t b : bytes) {
      if (f.push(b)) sum += sb::decode(f.packet()).axes[0];
    }
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * kPackets);
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(bytes.size()));
}
BENCHMARK(BM_SpaceballFrameAndDecode);

void BM_MagellanFrameAndDecode(benchmark::State& state) {
  const auto bytes = magellan_stream();
  mg::Framer f;
  int64_t sum = 0;
  for (auto _ : state) {
    for (uint8_t b : bytes) {
      if (f.push(b)) sum += mg::decode(f.packet()).axes[0];
    }
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * kPackets);
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(bytes.size()));
}
BENCHMARK(BM_MagellanFrameAndDecode);

void BM_HidDecodeAndMap(benchmark::State& state) {
  std::mt19937_64 rng(3);
  std::vector<std::array<uint8_t, 7>> reports;
  for (int i = 0; i < kPackets; ++i) {
    hid::Axes a;
    for (auto& v : a) v = static_cast<int16_t>(static_cast<int>(rng() % 701) - 350);
    reports.push_back(i % 2 ? hid::rotation_report(a) : hid::translation_report(a));
  }
  hid::Decoder d;
  mimic::devices::InputFrame f;
  for (auto _ : state) {
    for (const auto& r : reports) {
      d.feed(r);
      hid::to_frame(d.axes(), {}, f);
    }
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(state.iterations() * kPackets);
}
BENCHMARK(BM_HidDecodeAndMap);

}  // namespace
