// `mimic calibrate`: the wearer stands still in a T-pose (or N-pose) for a few seconds; the
// sensor-to-segment offsets and body proportions are measured and written as JSON.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/wearer_body.h"
#include "mimic/devices/source.h"
#include "mimic/rig/motion.h"
#include "mimic/service/tracker_source.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/model_refiner.h"
#include "mimic/solver/sensor_layout.h"
#include "mimic/sim/sensor_rig.h"

namespace mimic::app::cmd_calibrate {
namespace {

constexpr const char* kName = "calibrate";

constexpr const char* kAbout =
    "Calibrates the trackers to the wearer: each sensor's rotation and translation on its body\n"
    "segment, and the body's proportions (height, spine, arms, legs), from a few seconds of\n"
    "standing still. Stand in a T-pose (arms straight out to the sides, palms down, feet under\n"
    "the hips) or an N-pose (arms hanging at the sides), anywhere, facing any way. The capture\n"
    "starts after a short countdown; a status line shows the sensors seen and how much they\n"
    "move. The calibration is refused, with the reason, when a sensor of the layout sends no\n"
    "data or the wearer moves more than the tolerance; nothing is written then.\n"
    "\n"
    "Sensors are numbered as in the layout (sensor id = position in the list):\n"
    "  3    head, l_hand, r_hand\n"
    "  6    3 + pelvis, l_foot, r_foot\n"
    "  11   6 + l_upper_arm, r_upper_arm, l_thigh, r_thigh, chest\n"
    "  all  one per skeleton joint\n"
    "Strap them: head on top, hands on the back of the hand, pelvis on the sacrum, feet on the\n"
    "instep, upper arms on the outside, thighs on the front, chest on the sternum.";

struct Options {
  std::string source, out, layout, pose = "tpose", body_out, body;
  double seconds = 2.0, countdown_s = 3.0, max_cm = 3.0, max_deg = 6.0, floor_y = 0.0, move_s = 0.0;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer("exit status: 0 written, 1 refused or source failure, 2 usage error");
  p->add_option("--source", o.source,
                "tracker source, e.g. flock:/dev/ttyUSB0?birds=6, replay:stand.mlog,\nsim:idle?sensors=6, "
                "vrpn:Tracker0@localhost?layout=6, osc-trackers:9000\n(docs/hardware.md)")
      ->type_name("SRC")
      ->required();
  p->add_option("--out", o.out, "file to write (written atomically)")->type_name("CALIB.json")->required();
  p->add_option(
       "--layout", o.layout,
       "the sensor layout (default: the source's sensors= parameter, a network tracker's\nlayout= or map=, else 6)")
      ->check(CLI::IsMember(solver::standard_layout_names()));
  p->add_option("--pose", o.pose, "the pose stood in")
      ->check(cli::parsed_by(solver::parse_calibration_pose, "tpose|npose"));
  p->add_option("--seconds", o.seconds, "length of the capture")
      ->check(cli::finite_range(0, 60, cli::Bound::exclusive));
  p->add_option("--countdown", o.countdown_s, "time to get into the pose before the capture (0 = none)")
      ->check(cli::finite_range(0, 60));
  p->add_option("--max-motion-cm", o.max_cm, "refuse if a sensor moves farther than this")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_option("--max-motion-deg", o.max_deg, "refuse if a sensor turns more than this")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_option("--floor-y", o.floor_y, "floor height in tracker coordinates when no foot sensor shows it")
      ->check(cli::finite_range(-1e3, 1e3));
  p->add_option("--move", o.move_s,
                "after the stand-still, S seconds of moving about (bend elbows and\n"
                "knees, roll wrists and ankles, turn the head, take a few steps): the\n"
                "joint centres between neighbouring sensors and the elbow and knee\n"
                "are found from the motion and written too (layouts 11 and all;\n"
                "0: stand-still only)")
      ->check(cli::finite_range(0, 600));
  p->add_option("--body-out", o.body_out,
                "also write the wearer's body: the body (--body) given the wearer's height,\n"
                "spine origin, shoulder and hip width, and limb lengths; the calibration\n"
                "names it, so `mimic run --calibration` uses it (docs/body-model.md)")
      ->type_name("BODY.json");
  p->add_option("--body", o.body, "the body --body-out starts from (file or preset:NAME; default built-in)")
      ->type_name("FILE");
  return p.parse(argv);
}

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Samples are read (and dropped) while the wearer gets into the pose, so the source does not
// back up.
void count_down(devices::SensorSource& source, double countdown_s, std::vector<devices::SensorSample>& buffer,
                const char* end_status) {
  const auto start = Clock::now();
  int last_shown = -1;
  while (seconds_since(start) < countdown_s) {
    source.poll(buffer);
    const int left = static_cast<int>(std::ceil(countdown_s - seconds_since(start)));
    if (left != last_shown) {
      std::printf("get into the pose: capture starts in %d s   %s", left, end_status);
      std::fflush(stdout);
      last_shown = left;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

// The stand-still, with a live status line: sensors seen and the largest spread so far.
std::vector<devices::SensorSample> capture_still(devices::SensorSource& source, const solver::SensorLayout& layout,
                                                 double seconds, std::vector<devices::SensorSample>& buffer,
                                                 const char* end_status) {
  std::vector<devices::SensorSample> capture;
  capture.reserve(static_cast<size_t>(seconds * 200.0 * static_cast<double>(layout.bindings.size())) + 1024);
  std::map<uint16_t, glm::vec3> first_seen;
  float spread_mm = 0;
  const auto start = Clock::now();
  double next_status = 0;
  for (;;) {
    const double t = seconds_since(start);
    const size_t n = source.poll(buffer);
    for (size_t i = 0; i < n; ++i) {
      const auto& s = buffer[i];
      capture.push_back(s);
      if (!(s.flags & devices::kSampleValid)) continue;
      auto [it, fresh] = first_seen.try_emplace(s.sensor, s.position_m);
      if (!fresh) spread_mm = std::max(spread_mm, 1000.0f * glm::length(s.position_m - it->second));
    }
    if (t >= next_status || t >= seconds) {
      int seen = 0;
      for (const auto& b : layout.bindings) seen += first_seen.count(b.sensor) ? 1 : 0;
      std::printf("capturing %.1f/%.1f s  sensors %d/%zu  samples %zu  motion %.0f mm   %s", std::min(t, seconds),
                  seconds, seen, layout.bindings.size(), capture.size(), spread_mm, end_status);
      std::fflush(stdout);
      next_status = t + 0.2;
    }
    if (t >= seconds) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::printf("\n");
  return capture;
}

// Functional calibration: what --move seconds of motion show that a stand-still cannot (joint
// centres between neighbouring sensors, elbow and knee lengths). `cal` unchanged when the layout
// has nothing to refine.
Status refine_by_motion(devices::SensorSource& source, const std::string& layout_name, double move_s,
                        std::vector<devices::SensorSample>& buffer, const char* end_status, solver::Calibration& cal) {
  auto model = solver::make_solver_model(cal);
  if (!model) return tl::unexpected(model.error());
  solver::ModelRefiner refiner(cal, *model, 120.0);
  if (refiner.centres().pair_count() == 0 && refiner.limbs().observable_count() == 0) {
    std::printf("layout %s has no neighbouring sensors and no tracked elbow or knee to refine: --move skipped\n",
                layout_name.c_str());
    return {};
  }
  std::printf(
      "now move for %.0f s: bend the elbows and knees, roll the wrists and ankles, turn the head,\n"
      "take a few steps\n",
      move_s);
  const auto start = Clock::now();
  double next_status = 0;
  size_t moved = 0;
  for (;;) {
    const double t = seconds_since(start);
    const size_t n = source.poll(buffer);
    if (n > 0) refiner.add(std::span<const devices::SensorSample>(buffer.data(), n), *model), moved += n;
    if (t >= next_status || t >= move_s) {
      int ready = 0;
      for (const auto& f : refiner.centres().fits()) ready += f.samples > 0 ? 1 : 0;
      std::printf("moving %.1f/%.1f s  samples %zu  joint centres seen %d/%d   %s", std::min(t, move_s), move_s, moved,
                  ready, refiner.centres().pair_count(), end_status);
      std::fflush(stdout);
      next_status = t + 0.2;
    }
    if (t >= move_s) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::printf("\n");
  int joints = 0, limbs = 0;
  auto refined = refiner.refined_calibration(&joints, &limbs);
  if (!refined) return tl::unexpected(refined.error());
  std::printf("refined from the motion: %d joint centres, %d elbow/knee lengths\n", joints, limbs);
  cal = std::move(*refined);
  return {};
}

void print_calibration(const solver::Calibration& cal, const std::string& out) {
  std::printf("calibrated: height %.2f m, facing %.0f deg, %d samples over %.2f s, stillness %.1f mm / %.1f deg\n",
              cal.height_m, cal.heading_deg, cal.samples, cal.duration_s, cal.max_motion_mm, cal.max_motion_deg);
  const rig::Skeleton fitted = *rig::Skeleton::build(cal.skeleton);
  const rig::Proportions p = rig::measure_proportions(fitted);
  std::printf("body: upper arm %.3f m, forearm %.3f m, thigh %.3f m, shin %.3f m, shoulders %.3f m, hips %.3f m\n",
              p.upper_arm_m, p.forearm_m, p.thigh_m, p.shin_m, p.shoulder_width_m, p.hip_width_m);
  for (const auto& s : cal.sensors) {
    const glm::vec3 tr = s.segment_from_sensor.translation;
    const glm::quat q = s.segment_from_sensor.rotation;
    const float angle = glm::degrees(2.0f * std::acos(std::min(1.0f, std::abs(q.w))));
    std::printf("  sensor %2u %-12s on %-12s at (%6.3f %6.3f %6.3f) m, turned %5.1f deg\n", s.sensor, s.name.c_str(),
                s.segment.c_str(), tr.x, tr.y, tr.z, angle);
  }
  std::printf("wrote %s\n", out.c_str());
}

// What the stand-still makes of the start body itself: its skeleton worn by simulated sensors of
// the same layout, standing still without noise, calibrated alike. The wearer is measured against
// this, so the skeleton fit's own biases (wrists and shoulders a few millimetres out) cancel. The
// body's own skeleton where no such simulation stands in (a layout of a network tracker's own, an
// N-pose).
rig::SkeletonDesc calibrated_reference(const avatar::BodyModel& base, const std::string& layout_name,
                                       const solver::CalibrationOptions& options) {
  auto skeleton = rig::Skeleton::build(base.skeleton);
  auto tracking = rig::Skeleton::build(solver::tracking_skeleton_desc());
  if (!skeleton || !tracking || options.pose != solver::CalibrationPose::t_pose) return base.skeleton;
  auto motion = rig::make_builtin_motion("idle", *skeleton);
  auto mounts = sim::make_layout(layout_name, *skeleton);
  auto layout = solver::standard_layout(layout_name, *tracking);
  if (!motion || !mounts || !layout) return base.skeleton;
  sim::RigConfig config;
  config.sensors = std::move(*mounts);
  auto rig = sim::SensorRig::create(std::shared_ptr<const rig::Motion>(std::move(*motion)), std::move(config));
  if (!rig) return base.skeleton;
  std::vector<devices::SensorSample> capture, tick(static_cast<size_t>(rig->sensor_count()));
  for (int k = 0; k < 100; ++k) {
    rig->step(tick);
    capture.insert(capture.end(), tick.begin(), tick.end());
  }
  auto cal = solver::calibrate(solver::tracking_skeleton_desc(), *layout, capture, options);
  return cal ? cal->skeleton : base.skeleton;
}

// The wearer's body from the calibrated skeleton: its proportions against what the calibration
// makes of the start body (calibrated_reference).
Status write_wearer_body(const Options& o, const std::string& layout_name, const solver::CalibrationOptions& options,
                         solver::Calibration& cal) {
  auto base = body_from_path(o.body);
  if (!base) return tl::unexpected(base.error());
  auto reference = rig::Skeleton::build(calibrated_reference(*base, layout_name, options));
  if (!reference) return tl::unexpected(reference.error());
  auto wearer = rig::Skeleton::build(cal.skeleton);
  if (!wearer) return tl::unexpected(wearer.error());
  const avatar::WearerRatios r =
      avatar::wearer_ratios(avatar::measure_build(*wearer), avatar::measure_build(*reference));
  auto body = avatar::wearer_body(*base, r);
  if (!body) return tl::unexpected(body.error());
  body->name = "wearer";
  if (auto st = avatar::save_body_model(*body, o.body_out); !st) return st;
  namespace fs = std::filesystem;
  const fs::path folder = fs::absolute(fs::path(o.out)).parent_path();
  cal.body = fs::absolute(fs::path(o.body_out)).lexically_relative(folder).string();
  const avatar::BodyScaling s = avatar::scaling_for(r);
  std::printf(
      "wearer's body: height x%.3f, spine origin x%.3f, shoulders x%.3f, hips x%.3f, depth x%.3f; arms x%.3f, "
      "legs x%.3f; wrote %s\n",
      s.total_height, s.spine_origin_ratio, s.high_lateral_scaling, s.low_lateral_scaling, s.frontal_scaling,
      r.upper_arm, r.thigh, o.body_out.c_str());
  return {};
}

std::string layout_from_spec(const devices::SourceSpec& spec) {
  auto it = spec.params.find("sensors");
  return it == spec.params.end() ? "6" : it->second;
}

int run_calibrate(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  const auto pose = *solver::parse_calibration_pose(o.pose);
  auto spec = devices::parse_source_spec(o.source);
  if (!spec) return p.usage_error(spec.error().message);
  const rig::Skeleton base = *rig::Skeleton::build(solver::tracking_skeleton_desc());
  // A network tracker says in its spec where its sensors are worn (layout= or map=).
  const bool from_spec = o.layout.empty() && service::is_network_tracker(*spec);
  auto layout = from_spec ? service::network_tracker_layout(*spec, base)
                          : solver::standard_layout(o.layout.empty() ? layout_from_spec(*spec) : o.layout, base);
  if (!layout) return p.usage_error(layout.error().message);
  const std::string layout_name = layout->name;

  auto source = service::open_tracker_source(*spec);
  if (!source) return p.failure(source.error().message);
  if (auto st = (*source)->start(); !st) return p.failure(st.error().message);
  const char* end_status = isatty(fileno(stdout)) != 0 ? "\r" : "\n";
  std::printf("calibrating %zu sensors (layout %s) from %s\n", layout->bindings.size(), layout_name.c_str(),
              (*source)->status().description.c_str());
  std::printf("stand still in %s, facing any way; keep still until the capture ends\n",
              pose == solver::CalibrationPose::t_pose ? "a T-pose: arms straight out to the sides, palms down"
                                                      : "an N-pose: arms hanging at your sides");
  std::vector<devices::SensorSample> buffer(256);
  count_down(**source, o.countdown_s, buffer, end_status);
  const auto capture = capture_still(**source, *layout, o.seconds, buffer, end_status);

  solver::CalibrationOptions opt;
  opt.pose = pose;
  opt.max_motion_m = static_cast<float>(o.max_cm / 100.0);
  opt.max_motion_deg = static_cast<float>(o.max_deg);
  opt.floor_y_m = static_cast<float>(o.floor_y);
  auto cal = solver::calibrate(solver::tracking_skeleton_desc(), *layout, capture, opt);
  Status refined;
  if (cal && o.move_s > 0) refined = refine_by_motion(**source, layout_name, o.move_s, buffer, end_status, *cal);
  (*source)->stop();
  if (!cal) return p.failure(cal.error().message);
  if (!refined) return p.failure(refined.error().message);
  if (!o.body_out.empty())
    if (auto st = write_wearer_body(o, layout_name, opt, *cal); !st) return p.failure(st.error().message);
  if (auto st = solver::save_calibration(o.out, *cal); !st) return p.failure(st.error().message);
  print_calibration(*cal, o.out);
  return 0;
}

}  // namespace

MIMIC_COMMAND(calibrate, "calibrate", "measure sensor offsets and body proportions from a stand-still (T- or N-pose)",
              run_calibrate);

}  // namespace mimic::app::cmd_calibrate
