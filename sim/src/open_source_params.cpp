// Source-spec parameters of the simulated and replayed sources (no motion or driver code here,
// so tests can use them without the motion library).
#include <cmath>
#include <cstdlib>

#include "mimic/sim/open_source.h"
#include "mimic/sim/sim_source.h"

#if __has_include("mimic/devices/flock.h")
#include "mimic/devices/flock.h"
#define MIMIC_SIM_HAVE_FLOCK 1
#else
#define MIMIC_SIM_HAVE_FLOCK 0
#endif

namespace mimic::sim {

namespace {

Result<double> number(const devices::SourceSpec& spec, const char* key, double fallback) {
  const auto it = spec.params.find(key);
  if (it == spec.params.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || !std::isfinite(v))
    return fail(Errc::invalid_argument,
                "source '" + spec.text + "': " + key + " expects a number, got '" + it->second + "'");
  return v;
}

bool flag(const devices::SourceSpec& spec, const char* key) {
  const auto it = spec.params.find(key);
  if (it == spec.params.end()) return false;
  const std::string& v = it->second;
  return v == "1" || v == "true" || v == "yes" || v == "on";
}

}  // namespace

Result<RigConfig> rig_config_from_spec(const devices::SourceSpec& spec, const rig::Skeleton& skeleton) {
  RigConfig c;
  const auto layout_it = spec.params.find("sensors");
  auto layout = make_layout(layout_it == spec.params.end() ? "6" : layout_it->second, skeleton);
  if (!layout) return tl::unexpected(layout.error());
  c.sensors = std::move(*layout);
  struct Key {
    const char* key;
    double fallback;
    double scale;
    double* out;
  };
  double seed = 1, burst = 1, latency_ms = 0;
  const Key keys[] = {{"rate", 100.0, 1.0, &c.rate_hz},
                      {"noise_mm", 1.0, 1.0, &c.position_noise_mm},
                      {"noise_deg", 0.5, 1.0, &c.orientation_noise_deg},
                      {"drift_mm", 0.0, 1.0, &c.bias_walk_mm_per_sqrt_s},
                      {"drift_deg", 0.0, 1.0, &c.bias_walk_deg_per_sqrt_s},
                      {"latency_ms", 0.0, 1.0, &latency_ms},
                      {"dropout", 0.0, 1.0, &c.dropout_probability},
                      {"burst", 1.0, 1.0, &burst},
                      {"seed", 1.0, 1.0, &seed}};
  for (const auto& k : keys) {
    auto v = number(spec, k.key, k.fallback);
    if (!v) return tl::unexpected(v.error());
    *k.out = *v * k.scale;
  }
  if (seed < 0 || seed != std::floor(seed) || seed > 9.0e15)
    return fail(Errc::out_of_range, "source '" + spec.text + "': seed must be a non-negative integer");
  if (burst < 1 || burst != std::floor(burst) || burst > 1e6)
    return fail(Errc::out_of_range, "source '" + spec.text + "': burst must be a whole number of ticks ≥ 1");
  c.seed = static_cast<uint64_t>(seed);
  c.dropout_burst = static_cast<int>(burst);
  c.latency_s = latency_ms * 1e-3;
  return c;
}

Result<ReplayOptions> replay_options_from_spec(const devices::SourceSpec& spec) {
  ReplayOptions o;
  auto speed = number(spec, "speed", 1.0);
  if (!speed) return tl::unexpected(speed.error());
  auto from = number(spec, "from", 0.0);
  if (!from) return tl::unexpected(from.error());
  o.speed = *speed;
  o.from_s = *from;
  o.loop = flag(spec, "loop");
  return o;
}

LogHeader log_header_for(const devices::SourceSpec& spec, const devices::SensorSource& source) {
  LogHeader h;
  h.source = spec.text;
  h.device = source.status().description;
  if (const auto* sim = dynamic_cast<const SimSource*>(&source)) {
    const RigConfig& c = sim->rig().config();
    h.seed = c.seed;
    h.rate_hz = c.rate_hz;
    h.world_from_reference = c.world_from_reference;
    for (size_t i = 0; i < c.sensors.size(); ++i)
      h.sensors.push_back(
          {static_cast<uint16_t>(i), c.sensors[i].name, c.sensors[i].segment, c.sensors[i].segment_from_sensor});
    h.description = "simulated: motion '" + sim->rig().motion().name() + "'";
  } else if (const auto* replay = dynamic_cast<const ReplaySource*>(&source)) {
    const LogHeader& orig = replay->log().header;
    h.sensors = orig.sensors;
    h.seed = orig.seed;
    h.rate_hz = orig.rate_hz;
    h.world_from_reference = orig.world_from_reference;
    h.calibration_json = orig.calibration_json;
    h.device = orig.device;
    h.description = "re-recorded from a replay of '" + orig.source + "'";
  }
#if MIMIC_SIM_HAVE_FLOCK
  else if (const auto* flock = dynamic_cast<const devices::FlockSource*>(&source)) {
    // Known once start() has configured the flock: one sensor per bird, named by FBB address.
    const devices::FlockInfo info = flock->info();
    for (size_t i = 0; i < info.sensor_addresses.size(); ++i)
      h.sensors.push_back({static_cast<uint16_t>(i), "bird" + std::to_string(info.sensor_addresses[i]), "", {}});
    h.rate_hz = info.measurement_rate_hz;
    if (!info.model.empty()) h.description = "Flock of Birds " + info.model + " software " + info.software_revision;
  }
#endif
  return h;
}

}  // namespace mimic::sim
