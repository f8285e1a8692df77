// Latency of the Flock of Birds driver, end to end over a real pseudo-terminal: from the moment
// the virtual Flock writes a record's last byte to the pty, to (a) the driver's host timestamp
// and (b) the sample reaching a consumer that polls. Four birds, group mode, POS/QUAT, 115200
// baud, stream mode at 103.3 Hz. Reported as counters in microseconds.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>

#include "mimic/core/clock.h"
#include "mimic/core/percentile.h"
#include "mimic/core/thread_priority.h"
#include "mimic/devices/flock.h"
#include "mimic/sim/virtual_flock.h"

namespace {

namespace fl = mimic::devices::flock;

constexpr int kBirds = 4;
constexpr int kSlots = 800;  // sequence numbers 0..799 ride in the Z position (1 mm apart)
constexpr double kStepM = 0.001;

int seq_of_z(double z_m) { return static_cast<int>(std::lround(z_m / kStepM)) % kSlots; }

double percentile(std::vector<double> v, double p) { return mimic::percentile_in_place(v, p); }

// Arg: SCHED_FIFO priority for the simulator, the driver's reader and the consumer (0 = normal
// scheduling). With it the consumer polls every 20 us instead of spinning, so the figure is what
// a realtime loop polling that often would see.
void BM_FlockLatencyPtyToConsumer(benchmark::State& state) {
  const double seconds = 3.0;
  const int rt = static_cast<int>(state.range(0));
  bool consumer_rt = false;
  if (rt > 0) consumer_rt = mimic::set_thread_fifo(rt);
  std::vector<double> to_stamp_us, to_consumer_us;
  uint64_t resyncs = 0, records = 0;
  for (auto _ : state) {
    // written[address][seq] = host time the record's last byte went into the pty
    std::array<std::array<std::atomic<double>, kSlots>, kBirds + 1> written{};
    std::array<std::atomic<int>, kBirds + 1> next_seq{};
    mimic::sim::VirtualFlockConfig sc;
    sc.birds = kBirds;
    sc.auto_config_busy_s = 0.05;
    sc.boot_garbage = false;
    sc.realtime_priority = rt;
    sc.provider = [&](double, int bird, mimic::devices::SensorSample& out) {
      const int seq = next_seq[static_cast<size_t>(bird + 1)]++ % kSlots;
      out.position_m = glm::vec3(0.0f, 0.0f, static_cast<float>(seq * kStepM));
    };
    sc.on_record_written = [&](double t, int address, std::span<const uint8_t> bytes) {
      auto r = fl::decode_record(bytes, {fl::Format::position_quaternion, false, true});
      if (!r || address < 1 || address > kBirds) return;
      const fl::Measurement m = fl::from_raw(*r, fl::PositionRange::in36);
      written[static_cast<size_t>(address)][static_cast<size_t>(seq_of_z(m.position_in.x * 0.0254))] = t;
    };
    auto sim = mimic::sim::VirtualFlock::create(sc);
    if (!sim || !(*sim)->start()) {
      state.SkipWithError("virtual flock failed");
      return;
    }
    mimic::devices::FlockConfig dc;
    dc.path = (*sim)->slave_path();
    dc.birds = kBirds;
    dc.settle = std::chrono::milliseconds(20);
    dc.auto_config_wait = std::chrono::milliseconds(80);
    dc.realtime_priority = rt;
    mimic::devices::FlockSource driver(dc);
    if (auto s = driver.start(); !s) {
      state.SkipWithError(s.error().what().c_str());
      return;
    }
    std::vector<mimic::devices::SensorSample> buf(64);
    const double until = mimic::steady_now_s() + seconds;
    const double skip_until = mimic::steady_now_s() + 0.2;  // let the stream settle
    while (mimic::steady_now_s() < until) {
      const size_t n = driver.poll(buf);
      const double t_consumer = mimic::steady_now_s();
      for (size_t i = 0; i < n; ++i) {
        const auto& s = buf[i];
        if (s.sensor < 1 || s.sensor > kBirds || t_consumer < skip_until) continue;
        const double t_w = written[s.sensor][static_cast<size_t>(seq_of_z(s.position_m.z))];
        if (t_w <= 0) continue;
        to_stamp_us.push_back((s.host_time_s - t_w) * 1e6);
        to_consumer_us.push_back((t_consumer - t_w) * 1e6);
      }
      if (n == 0) {
        if (consumer_rt)
          std::this_thread::sleep_for(std::chrono::microseconds(20));
        else
          std::this_thread::yield();
      }
    }
    state.counters["reader_realtime"] = driver.info().realtime ? 1 : 0;
    resyncs = driver.status().resyncs;
    records = driver.status().records;
    driver.stop();
  }
  state.counters["records"] = static_cast<double>(records);
  state.counters["resyncs"] = static_cast<double>(resyncs);
  state.counters["stamp_p50_us"] = percentile(to_stamp_us, 0.50);
  state.counters["stamp_p99_us"] = percentile(to_stamp_us, 0.99);
  state.counters["consumer_p50_us"] = percentile(to_consumer_us, 0.50);
  state.counters["consumer_p90_us"] = percentile(to_consumer_us, 0.90);
  state.counters["consumer_p99_us"] = percentile(to_consumer_us, 0.99);
  state.counters["consumer_max_us"] = percentile(to_consumer_us, 1.0);
  if (rt > 0) mimic::set_thread_fifo(0);
}
BENCHMARK(BM_FlockLatencyPtyToConsumer)->Arg(0)->Arg(20)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
