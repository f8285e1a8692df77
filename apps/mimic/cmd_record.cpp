// mimic record: tracker samples from any source into a Mimic log (docs/log-format.md).
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <optional>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "cli.h"
#include "command.h"
#include "mimic/core/clock.h"
#include "stop_signal.h"
#include "mimic/devices/source.h"
#include "mimic/sim/log.h"
#include "mimic/sim/open_source.h"
#include "mimic/sim/raw_session.h"
#include "mimic/sim/replay_source.h"
#include "mimic/service/tracker_source.h"
#include "mimic/rig/skeleton.h"

namespace mimic::app::cmd_record {
namespace {

constexpr const char* kName = "record";
constexpr const char* kAbout =
    "Records the samples of a tracker source into a Mimic log (docs/log-format.md) until\n"
    "--duration seconds have passed, the source ends (a replay), or Ctrl-C. The log is\n"
    "flushed every quarter second and closed cleanly on Ctrl-C, so it is complete and valid\n"
    "up to the last sample.";

struct SensorCount {
  uint16_t id;
  std::string name;
  uint64_t samples = 0;
  uint64_t stale = 0;
};

std::string status_line(double elapsed_s, uint64_t samples, const std::vector<SensorCount>& sensors) {
  char head[96];
  std::snprintf(head, sizeof head, "%7.1f s  %9llu samples  %8.1f/s  stale:", elapsed_s,
                static_cast<unsigned long long>(samples),
                elapsed_s > 0 ? static_cast<double>(samples) / elapsed_s : 0.0);
  std::string line = head;
  if (sensors.empty()) line += " -";
  for (const auto& s : sensors) line += " " + s.name + "=" + std::to_string(s.stale);
  return line;
}

struct Options {
  std::string source, out;
  double duration_s = 0;
  long seed = -1;  // -1: not given
  bool quiet = false, raw = false;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer(
      "While recording, stderr shows a live status line when it is a terminal: elapsed time,\n"
      "samples, sample rate and, per sensor, how many samples were stale (dropped out).\n"
      "Exit status: 0 when the log was written, 1 on an I/O or source error, 2 on bad usage.");
  p->add_option("--source", o.source,
                "where samples come from:\n"
                "  sim:NAME     virtual body on a built-in motion (walk, idle)\n"
                "  bvh:CLIP     virtual body on a BVH clip\n"
                "  replay:FILE  another log\n"
                "  flock:PATH   Flock of Birds on a serial port\n"
                "  vrpn:DEVICE@HOST[:PORT]   a VRPN tracker (OptiTrack, Vicon, vrpn_server)\n"
                "  osc-trackers:[HOST:]PORT  VRChat-style OSC trackers (SlimeVR)\n"
                "  vmc:[HOST:]PORT?map=SERIAL:SEGMENT,...  a VMC sender's devices\n"
                "(see docs/hardware.md for their parameters)\n"
                "sim/bvh parameters: sensors=3|6|11|all rate=HZ noise_mm=MM noise_deg=DEG\n"
                "drift_mm=MM drift_deg=DEG latency_ms=MS dropout=P burst=TICKS seed=N,\n"
                "e.g. sim:walk?sensors=11&rate=120&noise_mm=2")
      ->type_name("SRC")
      ->required();
  p->add_option("--out", o.out, "log to write (created as FILE.part, renamed once its header is on disk)")
      ->type_name("FILE")
      ->required();
  p->add_option("--duration", o.duration_s, "stop after S seconds (default: until Ctrl-C or the source ends)")
      ->default_str("")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_option("--seed", o.seed, "seed of a simulated source (same as seed=N in --source)")
      ->default_str("")
      ->check(CLI::Range(0L, 0x7FFFFFFFL));
  p->add_flag("--raw", o.raw,
              "also keep every byte exchanged with a serial device (flock:), start-up\n"
              "included, so that `mimic replay --through-driver` can play the session\n"
              "back to the driver");
  p->add_flag("--quiet", o.quiet, "no live status line (a summary is still printed at the end)");
  return p.parse(argv);
}

// The source's spec with --seed folded in; a usage error's message when they do not go together.
Result<devices::SourceSpec> source_spec(const Options& o) {
  auto spec = devices::parse_source_spec(o.source);
  if (!spec) return spec;
  if (o.seed >= 0) {
    if (spec->scheme != "sim" && spec->scheme != "bvh")
      return fail(Errc::invalid_argument, "--seed applies to simulated sources (sim:, bvh:) only");
    if (spec->params.count("seed"))
      return fail(Errc::invalid_argument, "the seed is given twice (--seed and seed= in --source)");
    spec->params["seed"] = std::to_string(o.seed);
    spec->text += (spec->text.find('?') == std::string::npos ? "?seed=" : "&seed=") + std::to_string(o.seed);
  }
  if (o.raw && spec->scheme != "flock")
    return fail(Errc::invalid_argument, "--raw needs a serial device source (flock:PATH)");
  return spec;
}

int run(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  const double duration_s = o.duration_s;
  const std::string& out_path = o.out;
  auto spec = source_spec(o);
  if (!spec) return p.usage_error(spec.error().message);
  std::shared_ptr<sim::RawByteRecorder> raw;
  if (o.raw) raw = std::make_shared<sim::RawByteRecorder>();
  auto source = service::open_tracker_source(*spec, nullptr, raw);
  if (!source) return failure(kName, source.error().what());
  const rig::Skeleton skeleton = *rig::Skeleton::build(rig::default_skeleton_desc());
  if (auto st = (*source)->start(); !st) return failure(kName, st.error().what());
  const auto* replay = dynamic_cast<const sim::ReplaySource*>(source->get());

  const sim::LogHeader header = service::tracker_log_header(*spec, **source, skeleton);
  auto writer = sim::LogWriter::create(out_path, header);
  if (!writer) {
    (*source)->stop();
    return failure(kName, writer.error().what());
  }

  std::vector<SensorCount> sensors;
  for (const auto& s : header.sensors) sensors.push_back({s.id, s.name});
  auto counter = [&](uint16_t id) -> SensorCount& {
    for (auto& s : sensors)
      if (s.id == id) return s;
    sensors.push_back({id, std::to_string(id)});
    return sensors.back();
  };

  install_stop_handler();
  const bool live = !o.quiet && ::isatty(STDERR_FILENO);
  const double start = steady_now_s();
  double next_status = start;
  double next_flush = start + 0.25;
  uint64_t total = 0;
  std::vector<devices::SensorSample> buf(1024);
  std::string error;
  auto drain = [&]() {
    if (raw && error.empty())
      if (auto r = raw->write_to(*writer); !r) error = r.error().what();
    size_t n;
    while (error.empty() && (n = (*source)->poll(buf)) > 0) {
      for (size_t i = 0; i < n; ++i) {
        if (auto st = writer->append(buf[i]); !st) {
          error = st.error().what();
          break;
        }
        SensorCount& c = counter(buf[i].sensor);
        ++c.samples;
        if (buf[i].flags & devices::kSampleStale) ++c.stale;
        ++total;
      }
    }
  };
  while (!stop_requested() && error.empty()) {
    drain();
    const double t = steady_now_s();
    if (duration_s > 0 && t - start >= duration_s) break;
    if (replay && replay->finished()) break;
    // Also flush on the wall clock: a source that falls silent must not keep its last
    // samples in memory, where a crash would lose them.
    if (t >= next_flush) {
      if (auto st = writer->flush(); !st) error = st.error().what();
      next_flush = t + 0.25;
    }
    if (live && t >= next_status) {
      std::fprintf(stderr, "\r%s\033[K", status_line(t - start, total, sensors).c_str());
      next_status = t + 0.2;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (!stop_requested() && error.empty()) drain();
  (*source)->stop();
  if (raw && error.empty())  // the stop command the driver sent on the way out
    if (auto r = raw->write_to(*writer); !r) error = r.error().what();
  const double elapsed = steady_now_s() - start;
  if (auto st = writer->close(); !st && error.empty()) error = st.error().what();
  if (live) std::fprintf(stderr, "\r\033[K");
  std::fprintf(stderr, "%s\n", status_line(elapsed, total, sensors).c_str());
  if (!error.empty()) return failure(kName, error + " (the log is valid up to the last flushed sample)");
  std::fprintf(stderr, "mimic record: %s%llu samples in %.2f s to %s (%s)\n", stop_requested() ? "interrupted; " : "",
               static_cast<unsigned long long>(total), elapsed, out_path.c_str(), header.source.c_str());
  if (raw)
    std::fprintf(stderr, "mimic record: %llu raw bytes kept\n", static_cast<unsigned long long>(raw->bytes_seen()));
  const auto status = (*source)->status();
  if (!status.last_error.empty())
    std::fprintf(stderr, "mimic record: source reported: %s\n", status.last_error.c_str());
  return 0;
}

}  // namespace

MIMIC_COMMAND(record, "record", "record tracker samples from a source into a log file", run);

}  // namespace mimic::app::cmd_record
