// mimic sim flock: a virtual Ascension Flock of Birds on a pseudo-terminal.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli.h"
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

namespace mimic::app::cmd_sim_flock {
namespace {

constexpr const char* kName = "sim flock";
constexpr const char* kAbout =
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
    "stderr says when that happens.";

struct Options {
  sim::VirtualFlockConfig flock;  // birds, baud, seed, rate, faults and busy window, as parsed
  std::string motion, bvh, log;
  bool ert = false, no_ert = false;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer("Try: mimic sim flock --birds 4 &   then open flock:<path>?birds=4");
  p->add_option("--birds", o.flock.birds, "sensors (13 at most with --ert); 1 without --ert is a standalone unit")
      ->check(CLI::Range(1, 14));
  auto* motion = p->add_option("--motion", o.motion,
                               "built-in motion of the sensor rig. Without --motion or --bvh every\n"
                               "joint of the default body swings on its own sinusoid")
                     ->check(CLI::IsMember(rig::builtin_motion_names()));
  p->add_option("--bvh", o.bvh, "a BVH clip retargeted onto Mimic's skeleton (does not loop)")
      ->type_name("CLIP")
      ->excludes(motion);
  p->add_option("--baud", o.flock.baud, "the line's rate; the driver must use the same")
      ->check(CLI::IsMember({2400, 4800, 9600, 19200, 38400, 57600, 115200}));
  auto* ert = p->add_flag("--ert", o.ert,
                          "an extended range controller at FBB address 1 (144 in full scale); the\n"
                          "birds follow at addresses 2..N+1. Default: only when the motion needs it");
  p->add_flag("--no-ert", o.no_ert, "standard range (36 in) even when the motion needs more")->excludes(ert);
  p->add_option("--seed", o.flock.seed, "seed of the motion and of line faults");
  p->add_option("--log", o.log,
                "write a Mimic log (*.mlog): the poses served (ground truth, one sample\n"
                "per bird per record, on the simulator's clock) and every byte that\n"
                "crossed the line in either direction")
      ->type_name("FILE");
  p->add_option("--rate", o.flock.measurement_rate_hz, "measurement rate in Hz")->check(cli::finite_range(14, 144));
  p->add_option("--faults", o.flock.fault_rate,
                "probability per record of a line fault: a lost byte, a stray phased\n"
                "byte, a cut record")
      ->check(cli::finite_range(0, 1));
  p->add_option("--busy", o.flock.auto_config_busy_s, "seconds the master ignores commands after auto-configuration")
      ->check(cli::finite_range(0, 60));
  if (auto exit_code = p.parse(argv)) return exit_code;
  if (o.ert && o.flock.birds > 13) return p.usage_error("--birds must be 1-13 with --ert (the ERC takes an address)");
  return std::nullopt;
}

// The rig on a motion, stepped as the simulator's clock advances: every record served for a
// time t carries the rig's latest tick at or before t.
struct RigProvider {
  sim::SensorRig rig;
  std::vector<devices::SensorSample> tick;
};

// Samples the sensors' true world positions over the motion (at most 10 minutes of it, at
// 20 Hz) and places the transmitter where all of them stay in front of it.
Result<sim::FlockPlacement> place_for_motion(const std::shared_ptr<const rig::Motion>& motion,
                                             const sim::RigConfig& rc) {
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

// Where the sensors ride and what that needs of the Flock: the transmitter's place, the
// sensors' names and whether an extended range controller serves them.
struct Scene {
  rig::RigidTransform world_from_transmitter;
  std::vector<std::string> sensor_names;
  std::string motion_what = "sinusoids";
  bool ert = false;
};

Result<std::shared_ptr<const rig::Motion>> load_motion(const Options& o, Scene& scene) {
  if (!o.bvh.empty()) {
    auto m = rig::load_bvh_motion(o.bvh);
    if (!m) return tl::unexpected(m.error());
    scene.motion_what = "bvh:" + o.bvh;
    return std::shared_ptr<const rig::Motion>(std::move(*m));
  }
  auto skeleton = rig::Skeleton::build(rig::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto m = rig::make_builtin_motion(o.motion, *skeleton);
  if (!m) return tl::unexpected(m.error());
  scene.motion_what = "motion:" + o.motion;
  return std::shared_ptr<const rig::Motion>(std::move(*m));
}

// The sensor rig on --motion or --bvh drives the birds; the transmitter goes where the motion
// stays in front of it. An exit code when that cannot be done.
std::optional<int> ride_motion(const Options& o, const cli::Parser& p, sim::VirtualFlockConfig& cfg, Scene& scene) {
  auto motion = load_motion(o, scene);
  if (!motion) return p.failure(motion.error().what());
  // The smallest layout with enough sensors, first N of it.
  std::vector<sim::SensorMount> mounts;
  for (const char* layout : {"3", "6", "11", "all"}) {
    auto l = sim::make_layout(layout, (*motion)->skeleton());
    if (l && l->size() >= static_cast<size_t>(o.flock.birds)) {
      mounts.assign(l->begin(), l->begin() + o.flock.birds);
      break;
    }
  }
  if (mounts.empty()) return p.failure("no sensor layout has " + std::to_string(o.flock.birds) + " sensors");
  for (const auto& m : mounts) scene.sensor_names.push_back(m.name);
  sim::RigConfig rc;
  rc.sensors = std::move(mounts);
  rc.rate_hz = o.flock.measurement_rate_hz;
  rc.seed = o.flock.seed;
  auto placement = place_for_motion(*motion, rc);
  if (!placement) return p.failure(placement.error().what());
  scene.world_from_transmitter = placement->world_from_transmitter;
  if (!placement->fits_standard() && !o.ert && !o.no_ert) {
    if (o.flock.birds + 1 > 14) return p.usage_error("this motion needs --ert, which leaves room for 13 birds");
    scene.ert = true;
    std::fprintf(stderr,
                 "mimic sim flock: the motion spans %.2f m from the transmitter, beyond the standard\n"
                 "  36 in range: serving with an extended range controller (--no-ert to refuse)\n",
                 placement->needed_range_m);
  }
  if (!(scene.ert ? placement->fits_extended() : placement->fits_standard()))
    std::fprintf(stderr,
                 "mimic sim flock: warning: the motion spans %.2f m from the transmitter, beyond the %s\n"
                 "  range (%.2f m): some positions will saturate\n",
                 placement->needed_range_m, scene.ert ? "144 in" : "36 in",
                 scene.ert ? sim::kFlockExtendedRange_m : sim::kFlockStandardRange_m);
  rc.world_from_reference = scene.world_from_transmitter;
  auto rig = sim::SensorRig::create(*motion, std::move(rc));
  if (!rig) return p.failure(rig.error().what());
  auto state = std::make_shared<RigProvider>(RigProvider{std::move(*rig), {}});
  state->tick.resize(static_cast<size_t>(o.flock.birds));
  cfg.provider = [state](double t_s, int bird, devices::SensorSample& out) {
    while (state->rig.next_device_time_s() <= t_s) state->rig.step(state->tick);
    const auto& s = state->tick[static_cast<size_t>(bird)];
    out.position_m = s.position_m;
    out.orientation = s.orientation;
  };
  return std::nullopt;
}

// --log: every pose served, as the ground truth a driver's output can be compared with, and
// every byte on the line. The simulator calls both taps from its own thread.
struct LogTap {
  std::unique_ptr<sim::LogWriter> log;
  std::mutex mu;
};

Status attach_log(const Options& o, const Scene& scene, sim::VirtualFlockConfig& cfg, LogTap& tap) {
  sim::LogHeader h;
  for (int i = 0; i < o.flock.birds; ++i) {
    sim::LogSensor s;
    // Numbered as the driver numbers its samples (devices/flock.h): the bird's place in address order.
    const int address = o.flock.birds == 1 && !scene.ert ? 1 : i + 1 + (scene.ert ? 1 : 0);
    s.id = static_cast<uint16_t>(i);
    s.name = size_t(i) < scene.sensor_names.size() ? scene.sensor_names[size_t(i)] : "bird" + std::to_string(address);
    h.sensors.push_back(s);
  }
  h.source = "sim flock " + scene.motion_what;
  h.device = "virtual Flock of Birds, " + std::to_string(o.flock.birds) +
             (o.flock.birds == 1 ? " bird, " : " birds, ") + std::to_string(o.flock.baud) + " baud" +
             (scene.ert ? ", ERC" : "");
  h.description = "poses served by mimic sim flock (ground truth, transmitter frame)";
  h.seed = o.flock.seed;
  h.rate_hz = o.flock.measurement_rate_hz;
  h.world_from_reference = scene.world_from_transmitter;
  auto w = sim::LogWriter::create(o.log, h);
  if (!w) return tl::unexpected(w.error());
  tap.log = std::make_unique<sim::LogWriter>(std::move(*w));
  // Samples carry the simulator's time; raw chunks the host's monotonic time.
  cfg.provider = [inner = cfg.provider, &tap](double t_s, int bird, devices::SensorSample& out) {
    inner(t_s, bird, out);
    devices::SensorSample s = out;
    s.sensor = static_cast<uint16_t>(bird);
    s.host_time_s = t_s;
    s.device_time_s = t_s;
    std::lock_guard lock(tap.mu);
    tap.log->append(s);
  };
  cfg.on_bytes = [&tap](double host_time_s, bool to_host, std::span<const uint8_t> bytes) {
    std::lock_guard lock(tap.mu);
    tap.log->append_raw(host_time_s, to_host ? sim::RawDirection::from_device : sim::RawDirection::to_device, bytes);
  };
  return {};
}

// Serves until Ctrl-C, warning once when a driver would read wrong positions; the counts at exit.
void serve(sim::VirtualFlock& flock) {
  bool warned = false;
  while (!stop_requested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const sim::VirtualFlockStats st = flock.stats();
    if (!warned && (st.saturated_records > 0 || st.mirrored_records > 0)) {
      warned = true;
      std::fprintf(stderr, "mimic sim flock: warning: %s: a driver reads wrong positions (counts at exit)\n",
                   st.saturated_records > 0 ? "sensors beyond the transmitter's range, positions pinned at full scale"
                                            : "sensors behind the selected hemisphere, positions mirrored");
    }
  }
  flock.stop();
  const sim::VirtualFlockStats st = flock.stats();
  if (st.saturated_records > 0 || st.mirrored_records > 0)
    std::fprintf(stderr, "mimic sim flock: warning: %llu of %llu records saturated, %llu mirrored by the hemisphere\n",
                 static_cast<unsigned long long>(st.saturated_records),
                 static_cast<unsigned long long>(st.records_sent),
                 static_cast<unsigned long long>(st.mirrored_records));
  std::fprintf(stderr, "mimic sim flock: %llu records, %llu commands (%llu invalid), %llu faults injected\n",
               static_cast<unsigned long long>(st.records_sent), static_cast<unsigned long long>(st.commands),
               static_cast<unsigned long long>(st.invalid_commands),
               static_cast<unsigned long long>(st.faults_injected));
}

int run(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  sim::VirtualFlockConfig cfg = o.flock;
  // Without a motion: the transmitter behind the pelvis, facing +Z, the joints on sinusoids.
  Scene scene;
  scene.world_from_transmitter.translation = glm::vec3(0.0f, 1.0f, -0.5f);
  scene.ert = o.ert;
  cfg.provider = sim::make_builtin_flock_motion(cfg.seed);
  if (!o.motion.empty() || !o.bvh.empty())
    if (auto exit_code = ride_motion(o, p, cfg, scene)) return *exit_code;
  cfg.erc = scene.ert;
  LogTap tap;
  if (!o.log.empty())
    if (auto st = attach_log(o, scene, cfg, tap); !st) return p.failure(st.error().what());

  auto flock = sim::VirtualFlock::create(std::move(cfg));
  if (!flock) return p.failure(flock.error().what());
  install_stop_handler();
  if (auto s = (*flock)->start(); !s) return p.failure(s.error().what());
  std::printf("%s\n", (*flock)->slave_path().c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "mimic sim flock: %d %s at %d baud%s, %s; open flock:%s?birds=%d&baud=%d%s\n", o.flock.birds,
               o.flock.birds == 1 ? "bird" : "birds", o.flock.baud, scene.ert ? " with ERC" : "",
               scene.motion_what.c_str(), (*flock)->slave_path().c_str(), o.flock.birds, o.flock.baud,
               scene.ert ? "&erc=1" : "");
  serve(**flock);
  if (tap.log) {
    std::lock_guard lock(tap.mu);
    if (auto c = tap.log->close(); !c) return p.failure(c.error().what());
  }
  return 0;
}

}  // namespace

MIMIC_SIM_SUBCOMMAND(flock, "flock", "virtual Ascension Flock of Birds (RS-232, 1-14 birds, FBB)", run);

}  // namespace mimic::app::cmd_sim_flock
