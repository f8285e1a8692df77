// mimic sim flock: a virtual Ascension Flock of Birds on a pseudo-terminal.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "command.h"
#include "stop_signal.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/retarget.h"
#include "mimic/devices/flock_packet.h"
#include "mimic/sim/flock_placement.h"
#include "mimic/sim/log.h"
#include "mimic/sim/sensor_rig.h"
#include "mimic/sim/virtual_flock.h"
#include "sim_command.h"

namespace mimic::app {
namespace {

constexpr const char* kUsage =
    "usage: mimic sim flock [--birds N] [--motion NAME | --bvh CLIP] [--baud B] [--ert | --no-ert]\n"
    "                       [--seed S] [--log FILE] [--rate HZ] [--faults P] [--busy S]\n"
    "\n"
    "Serves a virtual Ascension Flock of Birds on a new pseudo-terminal and prints its path as\n"
    "the first line of stdout. It speaks the real RS-232 protocol (docs/devices-flock.md): the\n"
    "command set with RS232-TO-FBB address prefixes, EXAMINE/CHANGE parameters in the manual's\n"
    "sizes (status, revision 3.67, 25 MHz crystal, model 6DFOB/6DERC, error codes, flock status,\n"
    "auto-configuration with its busy window, group mode), the seven record formats with button\n"
    "and group bytes, point and stream modes, report rates and hemispheres. Stream records\n"
    "follow the measurement rate and leave the terminal at the pace of the baud rate. Any\n"
    "driver can open the path: flock:<path>?birds=N&baud=B for Mimic's own.\n"
    "Runs until Ctrl-C or SIGTERM.\n"
    "\n"
    "Sensors ride on a virtual body. Without --motion or --bvh the transmitter stands 0.5 m\n"
    "behind the pelvis at 1 m height facing the body's forward (the Flock's forward\n"
    "hemisphere). With a motion it is placed where the whole motion stays in front of it:\n"
    "centred on the sensors' extent across and up, 0.1 m behind the rearmost one, and an\n"
    "extended range controller is added when the motion does not fit the standard 36 in range\n"
    "(the built-in walk, a 1.2 m circle, needs one). Positions beyond the range saturate and\n"
    "positions behind the hemisphere come out mirrored, as on the real unit; a warning on\n"
    "stderr says when that happens.\n"
    "\n"
    "options:\n"
    "  --birds N     sensors, 1-14 (13 with --ert); 1 without --ert is a standalone unit\n"
    "                (default 1)\n"
    "  --motion NAME built-in motion of the sensor rig: idle, walk. Without --motion or\n"
    "                --bvh every joint of the default body swings on its own sinusoid\n"
    "  --bvh CLIP    a BVH clip retargeted onto Mimic's skeleton (does not loop)\n"
    "  --baud B      2400, 4800, 9600, 19200, 38400, 57600 or 115200 (default 115200); the\n"
    "                driver must use the same\n"
    "  --ert         an extended range controller at FBB address 1 (144 in full scale); the\n"
    "                birds follow at addresses 2..N+1. Default: only when the motion needs it\n"
    "  --no-ert      standard range (36 in) even when the motion needs more\n"
    "  --seed S      seed of the motion and of line faults (default 1)\n"
    "  --log FILE    write a Mimic log (*.mlog): the poses served (ground truth, one sample\n"
    "                per bird per record, on the simulator's clock) and every byte that\n"
    "                crossed the line in either direction\n"
    "  --rate HZ     measurement rate, 14-144 (default 103.3)\n"
    "  --faults P    probability per record of a line fault: a lost byte, a stray phased\n"
    "                byte, a cut record (default 0)\n"
    "  --busy S      how long the master ignores commands after auto-configuration\n"
    "                (default 0.35)\n"
    "\n"
    "Try: mimic sim flock --birds 4 &   then open flock:<path>?birds=4\n";

// The rig on a motion, stepped as the simulator's clock advances: every record served for a
// time t carries the rig's latest tick at or before t.
struct RigProvider {
  sim::SensorRig rig;
  std::vector<devices::SensorSample> tick;
};

// Samples the sensors' true world positions over the motion (at most 10 minutes of it, at
// 20 Hz) and places the transmitter where all of them stay in front of it.
Result<sim::FlockPlacement> place_for_motion(const std::shared_ptr<const rig::Motion>& motion, const sim::RigConfig& rc) {
  sim::RigConfig survey;
  survey.sensors = rc.sensors;
  survey.rate_hz = 20.0;
  auto rig = sim::SensorRig::create(motion, std::move(survey));
  if (!rig) return tl::unexpected(rig.error());
  std::vector<devices::SensorSample> tick(static_cast<size_t>(rig->sensor_count()));
  std::vector<glm::vec3> positions;
  const double span_s = std::min(motion->duration_s(), 600.0);
  while (rig->next_device_time_s() <= span_s) {
    rig->step(tick);
    for (int i = 0; i < rig->sensor_count(); ++i) positions.push_back(rig->true_world_from_sensor(i).translation);
  }
  return sim::place_flock_transmitter(positions);
}

int run(const std::vector<std::string>& argv) {
  constexpr const char* kName = "sim flock";
  Args args(argv, {"birds", "motion", "bvh", "baud", "seed", "log", "rate", "faults", "busy"}, {"ert", "no-ert"});
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  long birds = 1, baud = 115200, seed = 1;
  double rate = 103.3, faults = 0, busy = 0.35;
  if (!args.get_int("birds", birds) || !args.get_int("baud", baud) || !args.get_int("seed", seed) ||
      !args.get_double("rate", rate) || !args.get_double("faults", faults) || !args.get_double("busy", busy))
    return usage_error(kName, args.error());
  if (args.has("ert") && args.has("no-ert")) return usage_error(kName, "give --ert or --no-ert, not both");
  bool ert = args.has("ert");
  if (birds < 1 || birds + (ert ? 1 : 0) > 14) return usage_error(kName, "--birds must be 1-14 (1-13 with --ert)");
  const long bauds[] = {2400, 4800, 9600, 19200, 38400, 57600, 115200};
  if (std::find(std::begin(bauds), std::end(bauds), baud) == std::end(bauds))
    return usage_error(kName, "--baud must be one of 2400, 4800, 9600, 19200, 38400, 57600, 115200");
  if (rate < 14 || rate > 144) return usage_error(kName, "--rate must be 14-144 Hz");
  if (faults < 0 || faults > 1) return usage_error(kName, "--faults is a probability, 0-1");
  if (seed < 0) return usage_error(kName, "--seed must be >= 0");
  if (args.has("motion") && args.has("bvh")) return usage_error(kName, "give --motion or --bvh, not both");

  sim::VirtualFlockConfig cfg;
  cfg.birds = static_cast<int>(birds);
  cfg.baud = static_cast<int>(baud);
  cfg.seed = static_cast<uint64_t>(seed);
  cfg.measurement_rate_hz = rate;
  cfg.fault_rate = faults;
  cfg.auto_config_busy_s = busy;

  // Transmitter placement in the body's world: behind the pelvis, facing +Z.
  rig::RigidTransform world_from_transmitter;
  world_from_transmitter.translation = glm::vec3(0.0f, 1.0f, -0.5f);
  std::vector<std::string> sensor_names;
  std::string motion_what = "sinusoids";

  if (args.has("motion") || args.has("bvh")) {
    std::shared_ptr<const rig::Motion> motion;
    if (args.has("bvh")) {
      auto m = rig::load_bvh_motion(*args.get("bvh"));
      if (!m) return failure(kName, m.error().what());
      motion = std::move(*m);
      motion_what = "bvh:" + *args.get("bvh");
    } else {
      auto skeleton = rig::Skeleton::build(rig::default_skeleton_desc());
      if (!skeleton) return failure(kName, skeleton.error().what());
      auto m = rig::make_builtin_motion(*args.get("motion"), *skeleton);
      if (!m) return usage_error(kName, m.error().message);
      motion = std::move(*m);
      motion_what = "motion:" + *args.get("motion");
    }
    // The smallest layout with enough sensors, first N of it.
    std::vector<sim::SensorMount> mounts;
    for (const char* layout : {"3", "6", "11", "all"}) {
      auto l = sim::make_layout(layout, motion->skeleton());
      if (l && l->size() >= static_cast<size_t>(birds)) {
        mounts.assign(l->begin(), l->begin() + birds);
        break;
      }
    }
    if (mounts.empty()) return failure(kName, "no sensor layout has " + std::to_string(birds) + " sensors");
    for (const auto& m : mounts) sensor_names.push_back(m.name);
    sim::RigConfig rc;
    rc.sensors = std::move(mounts);
    rc.rate_hz = rate;
    rc.seed = static_cast<uint64_t>(seed);
    auto placement = place_for_motion(motion, rc);
    if (!placement) return failure(kName, placement.error().what());
    world_from_transmitter = placement->world_from_transmitter;
    if (!placement->fits_standard() && !args.has("ert") && !args.has("no-ert")) {
      if (birds + 1 > 14) return usage_error(kName, "this motion needs --ert, which leaves room for 13 birds");
      ert = true;
      std::fprintf(stderr, "mimic sim flock: the motion spans %.2f m from the transmitter, beyond the standard\n"
                           "  36 in range: serving with an extended range controller (--no-ert to refuse)\n",
                   placement->needed_range_m);
    }
    if (!(ert ? placement->fits_extended() : placement->fits_standard()))
      std::fprintf(stderr, "mimic sim flock: warning: the motion spans %.2f m from the transmitter, beyond the %s\n"
                           "  range (%.2f m): some positions will saturate\n",
                   placement->needed_range_m, ert ? "144 in" : "36 in",
                   ert ? sim::kFlockExtendedRange_m : sim::kFlockStandardRange_m);
    rc.world_from_reference = world_from_transmitter;
    auto rig = sim::SensorRig::create(motion, std::move(rc));
    if (!rig) return failure(kName, rig.error().what());
    auto state = std::make_shared<RigProvider>(RigProvider{std::move(*rig), {}});
    state->tick.resize(static_cast<size_t>(birds));
    cfg.provider = [state](double t_s, int bird, devices::SensorSample& out) {
      while (state->rig.next_device_time_s() <= t_s) state->rig.step(state->tick);
      const auto& s = state->tick[static_cast<size_t>(bird)];
      out.position_m = s.position_m;
      out.orientation = s.orientation;
    };
  } else {
    cfg.provider = sim::make_builtin_flock_motion(cfg.seed);
  }
  cfg.erc = ert;

  // --log: every pose served, as the ground truth a driver's output can be compared with.
  std::unique_ptr<sim::LogWriter> log;
  std::mutex log_mu;
  if (auto path = args.get("log")) {
    sim::LogHeader h;
    for (long i = 0; i < birds; ++i) {
      sim::LogSensor s;
      s.id = static_cast<uint16_t>(birds == 1 && !ert ? 1 : i + 1 + (ert ? 1 : 0));
      s.name = i < static_cast<long>(sensor_names.size()) ? sensor_names[static_cast<size_t>(i)] : "bird" + std::to_string(s.id);
      h.sensors.push_back(s);
    }
    h.source = "sim flock " + motion_what;
    h.device = "virtual Flock of Birds, " + std::to_string(birds) + (birds == 1 ? " bird, " : " birds, ") +
               std::to_string(baud) + " baud" + (ert ? ", ERC" : "");
    h.description = "poses served by mimic sim flock (ground truth, transmitter frame)";
    h.seed = static_cast<uint64_t>(seed);
    h.rate_hz = rate;
    h.world_from_reference = world_from_transmitter;
    auto w = sim::LogWriter::create(*path, h);
    if (!w) return failure(kName, w.error().what());
    log = std::make_unique<sim::LogWriter>(std::move(*w));
    // Samples carry the simulator's time; raw chunks the host's monotonic time.
    cfg.provider = [inner = cfg.provider, &log, &log_mu](double t_s, int bird, devices::SensorSample& out) {
      inner(t_s, bird, out);
      devices::SensorSample s = out;
      s.host_time_s = t_s;
      s.device_time_s = t_s;
      std::lock_guard lock(log_mu);
      log->append(s);
    };
    cfg.on_bytes = [&log, &log_mu](double host_time_s, bool to_host, std::span<const uint8_t> bytes) {
      std::lock_guard lock(log_mu);
      log->append_raw(host_time_s, to_host ? sim::RawDirection::from_device : sim::RawDirection::to_device, bytes);
    };
  }

  auto flock = sim::VirtualFlock::create(std::move(cfg));
  if (!flock) return failure(kName, flock.error().what());
  install_stop_handler();
  if (auto s = (*flock)->start(); !s) return failure(kName, s.error().what());
  std::printf("%s\n", (*flock)->slave_path().c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "mimic sim flock: %ld %s at %ld baud%s, %s; open flock:%s?birds=%ld&baud=%ld%s\n", birds,
               birds == 1 ? "bird" : "birds", baud, ert ? " with ERC" : "", motion_what.c_str(),
               (*flock)->slave_path().c_str(), birds, baud, ert ? "&erc=1" : "");
  bool warned = false;
  while (!stop_requested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const sim::VirtualFlockStats st = (*flock)->stats();
    if (!warned && (st.saturated_records > 0 || st.mirrored_records > 0)) {
      warned = true;
      std::fprintf(stderr, "mimic sim flock: warning: %s: a driver reads wrong positions (counts at exit)\n",
                   st.saturated_records > 0 ? "sensors beyond the transmitter's range, positions pinned at full scale"
                                            : "sensors behind the selected hemisphere, positions mirrored");
    }
  }
  (*flock)->stop();
  const sim::VirtualFlockStats st = (*flock)->stats();
  if (st.saturated_records > 0 || st.mirrored_records > 0)
    std::fprintf(stderr, "mimic sim flock: warning: %llu of %llu records saturated, %llu mirrored by the hemisphere\n",
                 static_cast<unsigned long long>(st.saturated_records), static_cast<unsigned long long>(st.records_sent),
                 static_cast<unsigned long long>(st.mirrored_records));
  std::fprintf(stderr, "mimic sim flock: %llu records, %llu commands (%llu invalid), %llu faults injected\n",
               static_cast<unsigned long long>(st.records_sent), static_cast<unsigned long long>(st.commands),
               static_cast<unsigned long long>(st.invalid_commands), static_cast<unsigned long long>(st.faults_injected));
  if (log) {
    std::lock_guard lock(log_mu);
    if (auto c = log->close(); !c) return failure(kName, c.error().what());
  }
  return 0;
}

}  // namespace

MIMIC_SIM_SUBCOMMAND(flock, "flock", "virtual Ascension Flock of Birds (RS-232, 1-14 birds, FBB)", kUsage, run);

}  // namespace mimic::app
