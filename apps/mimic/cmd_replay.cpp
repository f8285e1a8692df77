// mimic replay: plays a Mimic log back in time, or dumps it as CSV.
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "command.h"
#include "mimic/sim/clock.h"
#include "mimic/sim/log.h"
#include "mimic/sim/replay_source.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "replay";
constexpr const char* kUsage =
    "usage: mimic replay FILE [--speed X] [--loop] [--from S] [--csv] [--quiet]\n"
    "\n"
    "Plays a Mimic log (docs/log-format.md) back with its recorded timing and shows a status\n"
    "line on stderr, or with --csv prints every sample on stdout.\n"
    "\n"
    "options:\n"
    "  --speed X   playback speed: 1 real time (default), 2 twice as fast, 0 as fast as possible\n"
    "  --loop      start again at the end (until Ctrl-C); times keep increasing across passes\n"
    "  --from S    start S seconds after the first sample\n"
    "  --csv       one line per sample on stdout, no header line:\n"
    "                host_time_s,sensor,x_m,y_m,z_m,qw,qx,qy,qz\n"
    "              host_time_s as recorded (shifted by whole passes when looping); position in\n"
    "              metres and orientation (reference_from_sensor) in the tracker's reference\n"
    "              frame; all numbers with 6 decimals. Stale samples repeat the last good value.\n"
    "  --quiet     no status line\n"
    "\n"
    "A damaged or truncated log is replayed up to the damage; then the byte offset and record\n"
    "where it stopped are reported on stderr and the exit status is 1 (every good sample before\n"
    "it has been output). Exit status 2 on bad usage or when FILE is not a readable log.\n";

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

void install_stop_handler() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGPIPE, &sa, nullptr);
}

int run(const std::vector<std::string>& argv) {
  Args args(argv, {"speed", "from"}, {"loop", "csv", "quiet"});
  if (!args.ok()) return usage_error(kName, args.error());
  if (args.help()) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (args.positionals().size() != 1) return usage_error(kName, "expects exactly one log file");
  const std::string path = args.positionals()[0];
  sim::ReplayOptions options;
  if (!args.get_double("speed", options.speed) || !args.get_double("from", options.from_s))
    return usage_error(kName, args.error());
  options.loop = args.has("loop");
  const bool csv = args.has("csv");
  options.keep_log_times = csv;

  auto clock = std::make_shared<sim::SteadyClock>();
  auto opened = sim::ReplaySource::open(path, options, clock);
  if (!opened) {
    const Errc code = opened.error().code;
    if (code == Errc::out_of_range || code == Errc::invalid_argument) return usage_error(kName, opened.error().message);
    std::fprintf(stderr, "mimic replay: %s\n", opened.error().what().c_str());
    return 2;
  }
  sim::ReplaySource& source = **opened;
  const sim::LogContents& log = source.log();
  const bool live = !csv && !args.has("quiet") && ::isatty(STDERR_FILENO);
  if (!csv && !args.has("quiet"))
    std::fprintf(stderr, "replaying %s: %s, %zu sensors, %zu samples, %.3f s%s\n", path.c_str(),
                 log.header.source.empty() ? "unknown source" : log.header.source.c_str(), log.header.sensors.size(),
                 log.samples.size(),
                 log.samples.empty() ? 0.0 : log.samples.back().host_time_s - log.samples.front().host_time_s,
                 log.complete ? "" : " (damaged)");

  install_stop_handler();
  if (auto st = source.start(); !st) return failure(kName, st.error().what());
  const double start = clock->now_s();
  double next_status = start;
  uint64_t total = 0;
  std::vector<devices::SensorSample> buf(4096);
  std::vector<char> out;
  out.reserve(buf.size() * 96);
  char line[160];
  while (!g_stop) {
    const size_t n = source.poll(buf);
    total += n;
    if (csv && n > 0) {
      out.clear();
      for (size_t i = 0; i < n; ++i) {
        const size_t len = sim::format_sample_csv(buf[i], line);
        out.insert(out.end(), line, line + len);
      }
      if (std::fwrite(out.data(), 1, out.size(), stdout) != out.size()) break;  // reader went away
    }
    if (source.finished()) break;
    const double t = clock->now_s();
    if (live && t >= next_status) {
      std::fprintf(stderr, "\r%7.1f s  %9llu samples  %8.1f/s  pass %llu\033[K", t - start,
                   static_cast<unsigned long long>(total), t > start ? static_cast<double>(total) / (t - start) : 0.0,
                   static_cast<unsigned long long>(source.loops_completed() + 1));
      next_status = t + 0.2;
    }
    if (options.speed > 0 && n < buf.size()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  std::fflush(stdout);
  source.stop();
  if (live) std::fprintf(stderr, "\r\033[K");
  if (!csv && !args.has("quiet"))
    std::fprintf(stderr, "replayed %llu samples in %.2f s%s\n", static_cast<unsigned long long>(total),
                 clock->now_s() - start, g_stop ? " (interrupted)" : "");
  if (log.damage) {
    std::fprintf(stderr, "mimic replay: %s: damaged log, %s; %zu good samples before it\n", path.c_str(),
                 log.damage->what().c_str(), log.samples.size());
    return 1;
  }
  return 0;
}

}  // namespace

MIMIC_COMMAND(replay, "replay", "play a recorded log back in time, or dump it as CSV", kUsage, run);

}  // namespace mimic::app
