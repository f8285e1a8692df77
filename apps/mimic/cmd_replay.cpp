// mimic replay: plays a Mimic log back in time, or dumps it as CSV.
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli.h"
#include "command.h"
#include "mimic/core/text.h"
#include "stop_signal.h"
#include "mimic/core/clock.h"
#include "mimic/sim/log.h"
#include "mimic/sim/replay_source.h"
#include "mimic/devices/flock.h"
#include "mimic/devices/source.h"
#include "mimic/sim/open_source.h"
#include "mimic/sim/raw_session.h"
#include "mimic/sim/serial_device.h"

#include <nlohmann/json.hpp>

namespace mimic::app::cmd_replay {
namespace {

constexpr const char* kName = "replay";
constexpr const char* kAbout =
    "Plays a Mimic log (docs/log-format.md) back with its recorded timing and shows a status\n"
    "line on stderr, or with --csv prints every sample on stdout.";

struct Options {
  std::string path;
  sim::ReplayOptions replay;
  bool csv = false, quiet = false, through_driver = false, json = false;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer(
      "A damaged or truncated log is replayed around the damage: the reader skips to the next good\n"
      "record, so every good sample before and after is output. Each damaged stretch (byte offset,\n"
      "record, bytes skipped) and the samples lost are reported on stderr and the exit status is 1.\n"
      "Exit status 2 on bad usage or when FILE is not a readable log.");
  p->add_option("FILE", o.path, "the log to play")->required();
  auto* speed =
      p->add_option("--speed", o.replay.speed, "playback speed: 1 real time, 2 twice as fast, 0 as fast as possible")
          ->check(cli::finite_range(0, 1e6));
  auto* loop = p->add_flag("--loop", o.replay.loop,
                           "start again at the end (until Ctrl-C); times keep increasing across passes");
  auto* from = p->add_option("--from", o.replay.from_s, "start S seconds after the first sample")
                   ->check(cli::finite_range(0, INFINITY));
  auto* csv = p->add_flag("--csv", o.csv,
                          "one line per sample on stdout, no header line:\n"
                          "  host_time_s,sensor,x_m,y_m,z_m,qw,qx,qy,qz\n"
                          "host_time_s as recorded (shifted by whole passes when looping); position in\n"
                          "metres and orientation (reference_from_sensor) in the tracker's reference\n"
                          "frame; all numbers with 6 decimals. Stale samples repeat the last good value.");
  p->add_flag("--quiet", o.quiet, "no status line");
  auto* through = p->add_flag("--through-driver", o.through_driver,
                              "play the raw bytes of a session recorded with `mimic record --raw` back to\n"
                              "the real driver (a recorded device on a pseudo-terminal: start-up answers,\n"
                              "then the stream, at the recorded pace) and check that it decodes the\n"
                              "recorded samples again; prints the comparison. Exit status 1 when the\n"
                              "samples differ, or when the log is damaged")
                      ->excludes(speed)
                      ->excludes(loop)
                      ->excludes(from)
                      ->excludes(csv);
  p->add_flag("--json", o.json,
              "with --through-driver: one JSON object with chunks, bytes, samples_recorded,\n"
              "samples_decoded, identical, first_difference")
      ->needs(through);
  return p.parse(argv);
}

// Same sensor, position and orientation, bit for bit (times differ: the host stamps them).
// Every damaged stretch of `log`, one line each, and what it cost; nothing for a sound log.
void report_damage(const std::string& path, const sim::LogContents& log) {
  for (const auto& d : log.damages)
    std::fprintf(stderr, "mimic replay: %s: damaged log, %s\n", path.c_str(), d.what().c_str());
  if (log.damage)
    std::fprintf(stderr, "mimic replay: %s: %zu good samples kept, %llu bytes skipped%s\n", path.c_str(),
                 log.samples.size(), static_cast<unsigned long long>(log.bytes_skipped),
                 log.complete ? (", " + std::to_string(log.samples_lost) + " samples lost").c_str() : "");
}

bool same_sample(const devices::SensorSample& a, const devices::SensorSample& b) {
  return a.sensor == b.sensor && a.position_m == b.position_m && a.orientation.w == b.orientation.w &&
         a.orientation.x == b.orientation.x && a.orientation.y == b.orientation.y && a.orientation.z == b.orientation.z;
}

int replay_through_driver(const std::string& path, bool json) {
  auto log = sim::read_log(path);
  if (!log) {
    std::fprintf(stderr, "mimic replay: %s\n", log.error().what().c_str());
    return 2;
  }
  if (log->raw.empty())
    return failure(kName, path + ": the log has no raw bytes (record the session with mimic record --raw)");
  auto spec = devices::parse_source_spec(log->header.source);
  if (!spec || spec->scheme != "flock")
    return failure(kName, path + ": raw bytes of source '" + terminal_safe(log->header.source) +
                              "': only Flock of Birds sessions (flock:) play back through a driver");
  auto config = devices::flock_config_from_spec(*spec);
  if (!config) return failure(kName, path + ": " + config.error().message);
  auto device = std::make_unique<sim::RecordedSerialDevice>(log->raw, static_cast<unsigned>(config->baud));
  const uint64_t to_send = device->bytes_to_send();
  uint64_t chunk_bytes = 0;
  for (const auto& c : log->raw) chunk_bytes += c.bytes.size();
  auto server = sim::PtyServer::start(std::move(device), "");
  if (!server) return failure(kName, server.error().what());
  spec->target = (*server)->path();
  auto source = sim::open_sensor_source(*spec);
  if (!source) return failure(kName, source.error().what());
  if (!json)
    std::fprintf(stderr, "playing %zu raw chunks (%llu bytes) of %s to the Flock driver on %s\n", log->raw.size(),
                 static_cast<unsigned long long>(chunk_bytes), terminal_safe(log->header.source).c_str(),
                 spec->target.c_str());
  install_stop_handler(true);
  std::vector<devices::SensorSample> decoded, buf(1024);
  decoded.reserve(log->samples.size() + 64);
  std::string error;
  if (auto st = (*source)->start(); !st) error = "the driver's start-up failed: " + st.error().message;
  using clock = std::chrono::steady_clock;
  const double recorded_s = log->raw.back().host_time_s - log->raw.front().host_time_s;
  const auto deadline = clock::now() + std::chrono::duration<double>(recorded_s + 10.0);
  // Once every byte is out, the driver is drained: until it has decoded every recorded sample and
  // then been quiet a moment (it may decode a few more), or quiet for long (a short decode). A
  // fixed wait after the last byte lost samples when the machine was busy.
  bool sent = false;
  auto last_decoded = clock::now();
  while (error.empty() && !stop_requested() && clock::now() < deadline) {
    const size_t n = (*source)->poll(buf);
    decoded.insert(decoded.end(), buf.begin(), buf.begin() + static_cast<long>(n));
    const auto now = clock::now();
    if (n > 0) last_decoded = now;
    if (!sent && (*server)->stats().bytes_out >= to_send) {
      sent = true;
      last_decoded = now;  // the quiet time counts from the last byte out
    }
    const auto quiet = now - last_decoded;
    if (sent && ((decoded.size() >= log->samples.size() && quiet > std::chrono::milliseconds(200)) ||
                 quiet > std::chrono::seconds(3)))
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  (*source)->stop();
  (*server)->stop();
  // The recording and the driver's output, sample by sample.
  size_t identical = 0, first_difference = SIZE_MAX;
  const size_t common = std::min(decoded.size(), log->samples.size());
  for (size_t i = 0; i < common; ++i) {
    if (same_sample(decoded[i], log->samples[i]))
      ++identical;
    else if (first_difference == SIZE_MAX)
      first_difference = i;
  }
  // The driver may decode a few more: bytes it read after the recording loop's last poll.
  const bool all_same = error.empty() && identical == log->samples.size() && decoded.size() >= log->samples.size();
  if (json) {
    nlohmann::json j{
        {"chunks", log->raw.size()},
        {"bytes", chunk_bytes},
        {"samples_recorded", log->samples.size()},
        {"samples_decoded", decoded.size()},
        {"identical", identical},
        {"first_difference", first_difference == SIZE_MAX ? nlohmann::json(nullptr) : nlohmann::json(first_difference)},
        {"error", error},
        {"damaged", log->damage.has_value()}};
    if (log->damage) j["damage"] = log->damage->what();
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::fprintf(stderr, "the driver decoded %zu samples; the recording has %zu; %zu identical%s\n", decoded.size(),
                 log->samples.size(), identical, all_same ? " (all recorded samples)" : "");
    if (first_difference != SIZE_MAX)
      std::fprintf(stderr, "first difference at sample %zu (sensor %u)\n", first_difference,
                   log->samples[first_difference].sensor);
    if (!error.empty()) std::fprintf(stderr, "mimic replay: %s\n", error.c_str());
  }
  // A damaged recording cannot vouch for the driver, whatever matched.
  report_damage(path, *log);
  return all_same && !log->damage ? 0 : 1;
}

int run(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  const std::string& path = o.path;
  if (o.through_driver) return replay_through_driver(path, o.json);
  sim::ReplayOptions options = o.replay;
  const bool csv = o.csv;
  options.keep_log_times = csv;

  auto clock = std::make_shared<SteadyClock>();
  auto opened = sim::ReplaySource::open(path, options, clock);
  if (!opened) {
    const Errc code = opened.error().code;
    if (code == Errc::out_of_range || code == Errc::invalid_argument) return usage_error(kName, opened.error().message);
    std::fprintf(stderr, "mimic replay: %s\n", opened.error().what().c_str());
    return 2;
  }
  sim::ReplaySource& source = **opened;
  const sim::LogContents& log = source.log();
  const bool live = !csv && !o.quiet && ::isatty(STDERR_FILENO);
  if (!csv && !o.quiet)
    std::fprintf(stderr, "replaying %s: %s, %zu sensors, %zu samples, %.3f s%s\n", path.c_str(),
                 log.header.source.empty() ? "unknown source" : terminal_safe(log.header.source).c_str(),
                 log.header.sensors.size(), log.samples.size(),
                 log.samples.empty() ? 0.0 : log.samples.back().host_time_s - log.samples.front().host_time_s,
                 log.complete ? "" : " (damaged)");

  install_stop_handler(true);
  if (auto st = source.start(); !st) return failure(kName, st.error().what());
  const double start = clock->now_s();
  double next_status = start;
  uint64_t total = 0;
  std::vector<devices::SensorSample> buf(4096);
  std::vector<char> out;
  out.reserve(buf.size() * 96);
  char line[160];
  while (!stop_requested()) {
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
  if (!csv && !o.quiet)
    std::fprintf(stderr, "replayed %llu samples in %.2f s%s\n", static_cast<unsigned long long>(total),
                 clock->now_s() - start, stop_requested() ? " (interrupted)" : "");
  report_damage(path, log);
  return log.damage ? 1 : 0;
}

}  // namespace

MIMIC_COMMAND(replay, "replay", "play a recorded log back in time, or dump it as CSV", run);

}  // namespace mimic::app::cmd_replay
