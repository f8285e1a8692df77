// `mimic calibrate`: the wearer stands still in a T-pose (or N-pose) for a few seconds; the
// sensor-to-segment offsets and body proportions are measured and written as JSON.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "command.h"
#include "mimic/devices/source.h"
#include "mimic/sim/open_source.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/model_refiner.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "calibrate";

constexpr const char* kUsage =
    "usage: mimic calibrate --source SRC --out CALIB.json [options]\n"
    "\n"
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
    "instep, upper arms on the outside, thighs on the front, chest on the sternum.\n"
    "\n"
    "options:\n"
    "  --source SRC         tracker source, e.g. flock:/dev/ttyUSB0?birds=6, replay:stand.mlog,\n"
    "                       sim:idle?sensors=6 (required)\n"
    "  --out CALIB.json     file to write (required; written atomically)\n"
    "  --layout L           3, 6, 11 or all (default: the source's sensors= parameter, else 6)\n"
    "  --pose P             tpose or npose (default tpose)\n"
    "  --seconds S          length of the capture (default 2)\n"
    "  --countdown S        time to get into the pose before the capture (default 3; 0 = none)\n"
    "  --max-motion-cm X    refuse if a sensor moves farther than this (default 3)\n"
    "  --max-motion-deg X   refuse if a sensor turns more than this (default 6)\n"
    "  --floor-y M          floor height in tracker coordinates when no foot sensor shows it\n"
    "                       (default 0)\n"
    "  --move S             after the stand-still, S seconds of moving about (bend elbows and\n"
    "                       knees, roll wrists and ankles, turn the head, take a few steps): the\n"
    "                       joint centres between neighbouring sensors and the elbow and knee\n"
    "                       are found from the motion and written too (layouts 11 and all;\n"
    "                       default 0: stand-still only)\n"
    "  -h, --help           this text\n"
    "\n"
    "exit status: 0 written, 1 refused or source failure, 2 usage error\n";

std::string layout_from_spec(const devices::SourceSpec& spec) {
  auto it = spec.params.find("sensors");
  return it == spec.params.end() ? "6" : it->second;
}

int run_calibrate(const std::vector<std::string>& argv) {
  Args args(argv, {"source", "out", "layout", "pose", "seconds", "countdown", "max-motion-cm", "max-motion-deg", "floor-y", "move"},
            {});
  if (args.help()) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  const auto source_text = args.get("source");
  const auto out = args.get("out");
  if (!source_text) return usage_error(kName, "--source SRC is required");
  if (!out) return usage_error(kName, "--out CALIB.json is required");
  double seconds = 2.0, countdown = 3.0, max_cm = 3.0, max_deg = 6.0, floor_y = 0.0, move_s = 0.0;
  if (!args.get_double("seconds", seconds) || !args.get_double("countdown", countdown) || !args.get_double("move", move_s) ||
      !args.get_double("max-motion-cm", max_cm) || !args.get_double("max-motion-deg", max_deg) ||
      !args.get_double("floor-y", floor_y))
    return usage_error(kName, args.error());
  if (!(seconds > 0 && seconds <= 60)) return usage_error(kName, "--seconds must be within (0, 60]");
  if (!(countdown >= 0 && countdown <= 60)) return usage_error(kName, "--countdown must be within [0, 60]");
  if (!(move_s >= 0 && move_s <= 600)) return usage_error(kName, "--move must be within [0, 600] seconds");
  if (!(max_cm > 0) || !(max_deg > 0)) return usage_error(kName, "motion tolerances must be positive");
  auto pose = solver::parse_calibration_pose(args.get_or("pose", "tpose"));
  if (!pose) return usage_error(kName, pose.error().message);

  auto spec = devices::parse_source_spec(*source_text);
  if (!spec) return usage_error(kName, spec.error().message);
  const std::string layout_name = args.get_or("layout", layout_from_spec(*spec));
  const rig::Skeleton base = *rig::Skeleton::build(solver::tracking_skeleton_desc());
  auto layout = solver::standard_layout(layout_name, base);
  if (!layout) return usage_error(kName, layout.error().message);

  auto source = sim::open_sensor_source(*spec);
  if (!source) return failure(kName, source.error().message);
  if (auto st = (*source)->start(); !st) return failure(kName, st.error().message);
  const bool tty = isatty(fileno(stdout)) != 0;
  const char* end_status = tty ? "\r" : "\n";

  std::printf("calibrating %zu sensors (layout %s) from %s\n", layout->bindings.size(), layout_name.c_str(),
              (*source)->status().description.c_str());
  std::printf("stand still in %s, facing any way; keep still until the capture ends\n",
              *pose == solver::CalibrationPose::t_pose ? "a T-pose: arms straight out to the sides, palms down"
                                                       : "an N-pose: arms hanging at your sides");
  std::vector<devices::SensorSample> buffer(256), capture;
  capture.reserve(static_cast<size_t>(seconds * 200.0 * static_cast<double>(layout->bindings.size())) + 1024);
  using clock = std::chrono::steady_clock;
  // Countdown: samples are read (and dropped) so the source does not back up.
  const auto count_start = clock::now();
  int last_shown = -1;
  while (std::chrono::duration<double>(clock::now() - count_start).count() < countdown) {
    (*source)->poll(buffer);
    const int left = static_cast<int>(std::ceil(countdown - std::chrono::duration<double>(clock::now() - count_start).count()));
    if (left != last_shown) {
      std::printf("get into the pose: capture starts in %d s   %s", left, end_status);
      std::fflush(stdout);
      last_shown = left;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // Capture with a live status line: sensors seen and the largest spread so far.
  std::map<uint16_t, std::pair<glm::vec3, int>> first_seen;
  float spread_mm = 0;
  const auto cap_start = clock::now();
  double next_status = 0;
  for (;;) {
    const double t = std::chrono::duration<double>(clock::now() - cap_start).count();
    const size_t n = (*source)->poll(buffer);
    for (size_t i = 0; i < n; ++i) {
      const auto& s = buffer[i];
      capture.push_back(s);
      if (!(s.flags & devices::kSampleValid)) continue;
      auto [it, fresh] = first_seen.try_emplace(s.sensor, s.position_m, 0);
      ++it->second.second;
      if (!fresh) spread_mm = std::max(spread_mm, 1000.0f * glm::length(s.position_m - it->second.first));
    }
    if (t >= next_status || t >= seconds) {
      int seen = 0;
      for (const auto& b : layout->bindings) seen += first_seen.count(b.sensor) ? 1 : 0;
      std::printf("capturing %.1f/%.1f s  sensors %d/%zu  samples %zu  motion %.0f mm   %s", std::min(t, seconds), seconds, seen,
                  layout->bindings.size(), capture.size(), spread_mm, end_status);
      std::fflush(stdout);
      next_status = t + 0.2;
    }
    if (t >= seconds) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::printf("\n");

  solver::CalibrationOptions opt;
  opt.pose = *pose;
  opt.max_motion_m = static_cast<float>(max_cm / 100.0);
  opt.max_motion_deg = static_cast<float>(max_deg);
  opt.floor_y_m = static_cast<float>(floor_y);
  auto cal = solver::calibrate(solver::tracking_skeleton_desc(), *layout, capture, opt);
  if (!cal) {
    (*source)->stop();
    return failure(kName, cal.error().message);
  }
  if (move_s > 0) {
    // Functional calibration: what the motion shows that a stand-still cannot.
    auto model = solver::make_solver_model(*cal);
    if (!model) return failure(kName, model.error().message);
    solver::ModelRefiner refiner(*cal, *model, 120.0);
    if (refiner.centres().pair_count() == 0 && refiner.limbs().observable_count() == 0) {
      std::printf("layout %s has no neighbouring sensors and no tracked elbow or knee to refine: --move skipped\n",
                  layout_name.c_str());
    } else {
      std::printf("now move for %.0f s: bend the elbows and knees, roll the wrists and ankles, turn the head,\n"
                  "take a few steps\n", move_s);
      const auto move_start = clock::now();
      double next_move_status = 0;
      size_t moved = 0;
      for (;;) {
        const double t = std::chrono::duration<double>(clock::now() - move_start).count();
        const size_t n = (*source)->poll(buffer);
        if (n > 0) refiner.add(std::span<const devices::SensorSample>(buffer.data(), n), *model), moved += n;
        if (t >= next_move_status || t >= move_s) {
          int ready = 0;
          for (const auto& f : refiner.centres().fits()) ready += f.samples > 0 ? 1 : 0;
          std::printf("moving %.1f/%.1f s  samples %zu  joint centres seen %d/%d   %s", std::min(t, move_s), move_s, moved,
                      ready, refiner.centres().pair_count(), end_status);
          std::fflush(stdout);
          next_move_status = t + 0.2;
        }
        if (t >= move_s) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
      std::printf("\n");
      int joints = 0, limbs = 0;
      auto refined = refiner.refined_calibration(&joints, &limbs);
      if (!refined) {
        (*source)->stop();
        return failure(kName, refined.error().message);
      }
      std::printf("refined from the motion: %d joint centres, %d elbow/knee lengths\n", joints, limbs);
      cal = std::move(refined);
    }
  }
  (*source)->stop();
  if (auto st = solver::save_calibration(*out, *cal); !st) return failure(kName, st.error().message);
  std::printf("calibrated: height %.2f m, facing %.0f deg, %d samples over %.2f s, stillness %.1f mm / %.1f deg\n",
              cal->height_m, cal->heading_deg, cal->samples, cal->duration_s, cal->max_motion_mm, cal->max_motion_deg);
  const rig::Skeleton fitted = *rig::Skeleton::build(cal->skeleton);
  const rig::Proportions p = rig::measure_proportions(fitted);
  std::printf("body: upper arm %.3f m, forearm %.3f m, thigh %.3f m, shin %.3f m, shoulders %.3f m, hips %.3f m\n",
              p.upper_arm_m, p.forearm_m, p.thigh_m, p.shin_m, p.shoulder_width_m, p.hip_width_m);
  for (const auto& s : cal->sensors) {
    const glm::vec3 tr = s.segment_from_sensor.translation;
    const glm::quat q = s.segment_from_sensor.rotation;
    const float angle = glm::degrees(2.0f * std::acos(std::min(1.0f, std::abs(q.w))));
    std::printf("  sensor %2u %-12s on %-12s at (%6.3f %6.3f %6.3f) m, turned %5.1f deg\n", s.sensor, s.name.c_str(),
                s.segment.c_str(), tr.x, tr.y, tr.z, angle);
  }
  std::printf("wrote %s\n", out->c_str());
  return 0;
}

}  // namespace

MIMIC_COMMAND(calibrate, "calibrate", "measure sensor offsets and body proportions from a stand-still (T- or N-pose)",
              kUsage, run_calibrate);

}  // namespace mimic::app
