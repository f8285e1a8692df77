// `mimic eval-solver`: the joint-angle solver's accuracy on a BVH clip. The clip, retargeted onto
// Mimic's skeleton, is the ground truth; the simulator's sensor rig wears it (noise, mounting
// offsets); the solver calibrates on the clip's frame-0 T-pose and then sees only the sensor
// stream.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "command.h"
#include "mimic/rig/retarget.h"
#include "mimic/sim/sensor_rig.h"
#include "mimic/solver/model_refiner.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/calibration.h"
#include "mimic/solver/filters.h"
#include "mimic/solver/gait_metrics.h"
#include "mimic/solver/pose_error.h"
#include "mimic/solver/sensor_layout.h"

namespace mimic::app::cmd_eval_solver {
namespace {

constexpr const char* kName = "eval-solver";

constexpr const char* kAbout =
    "Measures the joint-angle solver on a BVH clip. The clip, retargeted onto Mimic's skeleton, is\n"
    "the ground truth. Virtual sensors ride on it (the simulator's sensor rig: strap positions of\n"
    "the layout, each strap turned by a random mounting rotation, Gaussian noise). The solver\n"
    "calibrates on one second of the clip's frame-0 T-pose, then solves every later frame from\n"
    "the sensor stream alone (it never sees the clip's skeleton or angles), through the input\n"
    "filters (One Euro, then a fixed-lag smoother that keeps straight motion on time) unless\n"
    "--no-filter (--no-smooth: the One Euro filters alone). As the wearer moves, the arm and leg\n"
    "link lengths are refined from the stream (functional calibration, solver/limb_refinement.h)\n"
    "unless --no-refine.\n"
    "\n"
    "Reported per layout, over every joint but the toes (Mimic's skeleton has no fingers), in world\n"
    "space without alignment:\n"
    "  mpjpe_cm         mean per-joint position error\n"
    "  mpjre_deg        mean per-joint rotation error (angle between solved and true joint frames)\n"
    "  end_effector_mm  mean position error of head, wrists and ankles\n"
    "  lower_cm         mean position error of hips, knees and ankles (lower_body_mpjpe_cm)\n"
    "  skate_mm         per stance of a true foot (ankle slower than 0.25 m/s, within 10 cm of\n"
    "                   its lowest), the solved foot's largest slide relative to it; mean\n"
    "  floor_mm         deepest point of a solved foot (ankle, toes, toe tip) under the floor\n"
    "                   (the lowest the true feet reach)\n"
    "  steps            stances after a swing of 10 cm or more, solved / truth\n"
    "  lag_ms           (JSON) the delay of the solved joints behind the truth: the shift of -2..+6\n"
    "                   samples with the least mean error, refined by a parabola\n"
    "  jitter_mm        mean |p[t+1] - 2 p[t] + p[t-1]| of solved joint positions per sample\n"
    "                   (second difference at the sample rate); jitter_truth_mm is the same for\n"
    "                   the ground truth\n"
    "  solve_us         wall time of filtering + solving one frame, p50 and p99";

// The motion frozen at one instant, raised by `lift_m`: the wearer holding the calibration pose.
class FrozenMotion final : public rig::Motion {
 public:
  FrozenMotion(std::shared_ptr<const rig::Motion> m, double t_s, float lift_m = 0)
      : m_(std::move(m)), t_(t_s), lift_m_(lift_m) {}
  const rig::Skeleton& skeleton() const override { return m_->skeleton(); }
  double duration_s() const override { return 1e9; }
  bool loops() const override { return false; }
  void sample(double, rig::Pose& out) const override {
    m_->sample(t_, out);
    out.root_position_m.y += lift_m_;
  }
  std::string name() const override { return m_->name() + "@frozen"; }

 private:
  std::shared_ptr<const rig::Motion> m_;
  double t_;
  float lift_m_;
};

// The lowest point of either foot (ankle, ball, toe tip), world y.
float lowest_foot_y(const rig::Skeleton& s, std::span<const rig::RigidTransform> world) {
  float low = std::numeric_limits<float>::infinity();
  for (const char* side : {"l_", "r_"}) {
    const int ankle = s.find_joint(std::string(side) + "ankle"), toes = s.find_joint(std::string(side) + "toes");
    if (ankle >= 0) low = std::min(low, world[ankle].translation.y);
    if (toes >= 0) low = std::min({low, world[toes].translation.y, world[toes].apply(s.tip_m(toes)).y});
  }
  return low;
}

// CMU's frame 0 is a synthetic rest pose whose feet float or sink centimetres off the floor the
// performer then moves on. A wearer calibrates standing on the floor they will walk on, and the
// tracking system knows where that floor is: the T-pose is raised so that its feet rest on the
// clip's floor (the lowest its feet reach), and the calibration is told the floor's height.
struct CalibrationStand {
  float lift_m = 0;   // added to the T-pose's height
  float floor_y = 0;  // the floor under it (soles), world
};

CalibrationStand calibration_stand(const rig::Motion& motion, double after_s, double rate_hz) {
  const rig::Skeleton& s = motion.skeleton();
  rig::Pose pose = s.zero_pose();
  std::vector<rig::RigidTransform> world(s.joint_count());
  motion.sample(0.0, pose);
  rig::forward_kinematics(s, pose, world);
  const float tpose_low = lowest_foot_y(s, world);
  // The straight-legged rest pose's soles, where the skeleton's standing height puts them.
  const float tpose_sole = pose.root_position_m.y - rig::standing_root_height_m(s);
  float clip_low = std::numeric_limits<float>::infinity();
  for (double t = after_s; t <= motion.duration_s(); t += 1.0 / rate_hz) {
    motion.sample(t, pose);
    rig::forward_kinematics(s, pose, world);
    clip_low = std::min(clip_low, lowest_foot_y(s, world));
  }
  if (!std::isfinite(clip_low) || !std::isfinite(tpose_low)) return {};
  const float lift = clip_low - tpose_low;
  return {lift, tpose_sole + lift};
}

// The motion from a later start (the clip after its T-pose).
class ShiftedMotion final : public rig::Motion {
 public:
  ShiftedMotion(std::shared_ptr<const rig::Motion> m, double shift_s) : m_(std::move(m)), shift_(shift_s) {}
  const rig::Skeleton& skeleton() const override { return m_->skeleton(); }
  double duration_s() const override { return std::max(0.0, m_->duration_s() - shift_); }
  bool loops() const override { return false; }
  void sample(double t, rig::Pose& out) const override { m_->sample(t + shift_, out); }
  std::string name() const override { return m_->name(); }

 private:
  std::shared_ptr<const rig::Motion> m_;
  double shift_;
};

struct Settings {
  double noise_mm = 1.0, noise_deg = 0.5, tilt_deg = 20.0, rate_hz = 120.0;
  double latency_ms = 0.0, dropout = 0.0;
  uint64_t seed = 1;
  long max_frames = -1;
  bool filter = true;
  bool smooth = true;
  bool refine = true;
  bool step = true;
  std::ostream* trace = nullptr;  // --trace: every joint of every frame, truth and solved
  CalibrationStand stand;         // where the clip's T-pose stands to calibrate (once per clip)
};

std::string base_name(const std::string& path) {
  const auto slash = path.find_last_of('/');
  std::string b = slash == std::string::npos ? path : path.substr(slash + 1);
  if (b.size() > 4 && b.substr(b.size() - 4) == ".bvh") b.resize(b.size() - 4);
  return b;
}

struct Run {
  solver::PoseErrorReport report;
  std::string error;
  solver::GaitReport gait{};
  int refined_limbs = 0;   // chains whose lengths the stream refined
  int refined_joints = 0;  // joint centres the stream refined
  double reach_mm = 0;     // mean distance of the solved end effectors from their sensors' targets
};

// The solver's view of the layout: which sensor is on which segment, and where the wearer was
// told to strap it (from its own layout table, matched by sensor name).
Result<solver::SensorLayout> nominal_layout(const std::string& layout_name, const auto& mounts) {
  const rig::Skeleton base = *rig::Skeleton::build(solver::tracking_skeleton_desc());
  auto nominal = solver::standard_layout(layout_name, base);
  if (!nominal) return tl::unexpected(nominal.error());
  solver::SensorLayout layout;
  layout.name = layout_name;
  for (size_t i = 0; i < mounts.size(); ++i) {
    solver::SensorBinding b{static_cast<uint16_t>(i), mounts[i].name, mounts[i].segment, glm::vec3(0.0f)};
    for (const auto& nb : nominal->bindings)
      if (nb.name == b.name) b.placement_m = nb.placement_m, b.link_fraction = nb.link_fraction;
    layout.bindings.push_back(b);
  }
  return layout;
}

// One CSV row per joint the solved skeleton shares with the truth: where each was and where the
// solver put it, for plotting a clip frame by frame.
void write_trace(std::ostream& out, const std::string& layout, double t_s, const rig::Skeleton& solved,
                 const rig::Skeleton& truth, std::span<const rig::RigidTransform> truth_world,
                 std::span<const rig::RigidTransform> solved_world) {
  for (int j = 0; j < solved.joint_count(); ++j) {
    const int tj = truth.find_joint(solved.joint_name(j));
    if (tj < 0) continue;
    const glm::vec3 a = truth_world[tj].translation, b = solved_world[j].translation;
    out << layout << ',' << t_s << ',' << solved.joint_name(j) << ',' << a.x << ',' << a.y << ',' << a.z << ',' << b.x
        << ',' << b.y << ',' << b.z << '\n';
  }
}

Run evaluate(const std::shared_ptr<const rig::Motion>& motion, double frame_time_s, const std::string& layout_name,
             const Settings& st) {
  const rig::Skeleton& truth = motion->skeleton();
  auto mounts = sim::make_layout(layout_name, truth);
  if (!mounts) return {{}, mounts.error().message};
  // Straps never sit square: a random turn of up to --tilt on every sensor.
  std::mt19937_64 rng(st.seed * 7919 + 17);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (auto& m : *mounts) {
    glm::vec3 axis(u(rng), u(rng), u(rng));
    if (glm::length(axis) < 1e-3f) axis = {0, 0, 1};
    m.segment_from_sensor.rotation =
        glm::angleAxis(glm::radians(static_cast<float>(st.tilt_deg)) * u(rng), glm::normalize(axis));
  }
  auto layout = nominal_layout(layout_name, *mounts);
  if (!layout) return {{}, layout.error().message};

  sim::RigConfig cfg;
  cfg.sensors = *mounts;
  cfg.rate_hz = st.rate_hz;
  cfg.position_noise_mm = st.noise_mm;
  cfg.orientation_noise_deg = st.noise_deg;
  cfg.seed = st.seed;
  cfg.latency_s = st.latency_ms / 1000.0;

  // Calibration: one second of the frame-0 T-pose, standing on the clip's floor.
  const CalibrationStand& stand = st.stand;
  auto cal_rig = sim::SensorRig::create(std::make_shared<FrozenMotion>(motion, 0.0, stand.lift_m), cfg);
  if (!cal_rig) return {{}, cal_rig.error().message};
  std::vector<devices::SensorSample> tick(mounts->size()), capture;
  const int cal_ticks = static_cast<int>(std::lround(st.rate_hz));
  for (int k = 0; k < cal_ticks; ++k) {
    cal_rig->step(tick);
    capture.insert(capture.end(), tick.begin(), tick.end());
  }
  solver::CalibrationOptions cal_options;
  cal_options.floor_y_m = stand.floor_y;
  auto cal = solver::calibrate(solver::tracking_skeleton_desc(), *layout, capture, cal_options);
  if (!cal) return {{}, "calibration failed: " + cal.error().message};
  solver::SolverOptions options;
  options.step = st.step;
  auto first_model = solver::make_solver_model(*cal, options);
  if (!first_model) return {{}, first_model.error().message};
  auto model = std::make_unique<solver::SolverModel>(std::move(*first_model));
  solver::ModelRefiner refiner(*cal, *model, st.rate_hz);
  double reach_sum_m = 0;
  long reach_n = 0;

  // The motion after the T-pose, with dropouts if asked for.
  cfg.seed = st.seed + 1;
  cfg.dropout_probability = st.dropout;
  cfg.dropout_burst = 3;
  auto motion_after = std::make_shared<ShiftedMotion>(motion, frame_time_s);
  auto rig = sim::SensorRig::create(motion_after, cfg);
  if (!rig) return {{}, rig.error().message};
  auto ctx = std::make_unique<solver::SolverContext>(*model);
  solver::SensorFilterConfig fc;
  fc.enabled = st.filter;
  if (!st.smooth) fc.position_smoother.window = fc.rotation_smoother.window = 1;
  fc.predict_s = static_cast<float>(st.latency_ms / 1000.0);  // the tracker's known latency
  solver::SensorFilterBank filters(static_cast<int>(mounts->size()), fc);
  rig::Pose pose = model->skeleton().zero_pose();
  std::vector<rig::RigidTransform> solved_world(model->skeleton().joint_count());
  solver::PoseErrorAccumulator acc(truth, model->skeleton());
  acc.set_rate_hz(st.rate_hz);
  solver::GaitAccumulator gait(truth, model->skeleton(), st.rate_hz);
  rig::Pose truth_pose = truth.zero_pose();
  std::vector<rig::RigidTransform> truth_world(truth.joint_count());
  long ticks = static_cast<long>(std::floor(motion_after->duration_s() * st.rate_hz)) + 1;
  if (st.max_frames >= 0) ticks = std::min(ticks, st.max_frames);
  for (long k = 0; k < ticks; ++k) {
    rig->step(tick);
    const auto t0 = std::chrono::steady_clock::now();
    if (st.refine && refiner.add(tick, *model)) {  // raw samples, before the filters
      if (auto next = refiner.rebuild()) {         // a new model and its scratch; the pose carries over
        model = std::move(*next);
        ctx = std::make_unique<solver::SolverContext>(*model);
      }
    }
    filters.process(tick);
    solver::SolveJob job{model.get(), tick, ctx.get(), &pose};
    job.Run();
    const auto t1 = std::chrono::steady_clock::now();
    rig::forward_kinematics(model->skeleton(), pose, solved_world);
    const double solve_us = std::chrono::duration<double, std::micro>(t1 - t0).count();
    // Reach: how far the solved head, wrists and ankles are from where their own sensors (as
    // calibrated, after the filters) put them — the IK's part of the end-effector error.
    for (const auto& smp : tick) {
      if (!(smp.flags & devices::kSampleValid) || smp.sensor >= model->mounts().size()) continue;
      const auto& m = model->mounts()[smp.sensor];
      if (m.sensor != smp.sensor || !solver::is_end_effector(m.segment)) continue;
      const int j = model->skeleton().find_joint(m.segment);
      const glm::vec3 target =
          rig::RigidTransform{smp.orientation, smp.position_m}.apply(m.segment_from_sensor.inverse().translation);
      reach_sum_m += glm::length(solved_world[j].translation - target);
      ++reach_n;
    }
    if (st.latency_ms > 0) {
      // The samples left the body latency ago; the avatar is judged against the body now.
      motion_after->sample(static_cast<double>(k) / st.rate_hz + st.latency_ms / 1000.0, truth_pose);
      rig::forward_kinematics(truth, truth_pose, truth_world);
      acc.add(truth_world, solved_world, solve_us);
      gait.add(truth_world, solved_world);
    } else {
      acc.add(rig->true_world_from_joint(), solved_world, solve_us);
      gait.add(rig->true_world_from_joint(), solved_world);
    }
    if (st.trace)
      write_trace(*st.trace, layout_name, static_cast<double>(k) / st.rate_hz, model->skeleton(), truth,
                  st.latency_ms > 0 ? std::span<const rig::RigidTransform>(truth_world) : rig->true_world_from_joint(),
                  solved_world);
  }
  return {acc.report(),
          {},
          gait.report(),
          refiner.refined_limbs(),
          refiner.refined_joints(),
          reach_n > 0 ? 1000.0 * reach_sum_m / static_cast<double>(reach_n) : 0.0};
}

// "MM,DEG": two non-negative finite numbers.
Result<std::pair<double, double>> parse_noise(std::string_view text) {
  const auto comma = text.find(',');
  const std::string a(text.substr(0, comma == std::string_view::npos ? text.size() : comma));
  const std::string b(comma == std::string_view::npos ? "" : text.substr(comma + 1));
  char* end_a = nullptr;
  char* end_b = nullptr;
  const double mm = std::strtod(a.c_str(), &end_a), deg = std::strtod(b.c_str(), &end_b);
  if (a.empty() || b.empty() || *end_a != '\0' || *end_b != '\0' || !(mm >= 0 && deg >= 0) || !std::isfinite(mm) ||
      !std::isfinite(deg))
    return fail(Errc::invalid_argument, "expects MM,DEG (two non-negative numbers), got '" + std::string(text) + "'");
  return std::pair{mm, deg};
}

struct Options {
  std::string clip_path, noise = "1,0.5";
  std::vector<std::string> layouts = {"3", "6", "11", "all"};
  long seed = 1, frames = -1;
  bool no_filter = false, no_smooth = false, no_refine = false, no_step = false, joints = false, json = false;
  std::string trace_path;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o, Settings& st) {
  p->footer("exit status: 0 done, 1 unreadable clip or failed calibration, 2 usage error");
  p->add_option("--bvh", o.clip_path, "clip to evaluate (CMU/cgspeed or Mimic joint names)")
      ->type_name("CLIP")
      ->required();
  p->add_option("--sensors", o.layouts, "layouts, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember(solver::standard_layout_names()));
  p->add_option("--noise", o.noise, "sensor noise, position std dev in mm and orientation in degrees")
      ->check(cli::parsed_by(parse_noise, "MM,DEG"));
  p->add_option("--tilt", st.tilt_deg, "largest random mounting rotation of a strap, degrees")
      ->check(cli::finite_range(0, 180));
  p->add_option("--rate", st.rate_hz, "sensor rate in Hz (the clip's frame rate by default)")
      ->check(cli::finite_range(0, 10000, cli::Bound::exclusive));
  p->add_option("--seed", o.seed, "noise and mounting seed")->check(CLI::NonNegativeNumber);
  p->add_option("--frames", o.frames, "evaluate at most N frames after the T-pose (default all)")
      ->default_str("")
      ->check(CLI::NonNegativeNumber);
  p->add_option("--latency", st.latency_ms,
                "tracker latency in ms; the filters predict that far ahead and the avatar is\n"
                "judged against the body at arrival time")
      ->check(cli::finite_range(0, 1000));
  p->add_option("--dropout", st.dropout, "chance per sample that a sensor falls silent for 3 samples")
      ->check(cli::finite_range(0, 1));
  p->add_flag("--no-filter", o.no_filter, "solve the raw samples (no One Euro filtering)");
  p->add_flag("--no-smooth", o.no_smooth, "no fixed-lag smoothing after the One Euro filters (more shake)");
  p->add_flag("--no-refine", o.no_refine, "keep the stand-still calibration (no refinement from the motion)");
  p->add_flag("--no-step", o.no_step, "untracked legs hang under the hips instead of stepping");
  p->add_option("--trace", o.trace_path,
                "write every frame's joints as CSV: layout,t_s,joint,true x,y,z,solved x,y,z (m)")
      ->type_name("FILE.csv");
  p->add_flag("--joints", o.joints, "also print the position error of every joint (table output)");
  p->add_flag("--json", o.json,
              "one JSON object per layout on stdout instead of the table; keys: clip,\n"
              "sensors, frames, joints, mpjpe_cm, mpjre_deg, end_effector_mm,\n"
              "end_effector_max_mm, end_effector_reach_mm (the solved end effectors'\n"
              "distance from their own sensors' targets: the IK's share), jitter,\n"
              "jitter_mm, jitter_truth_mm, lag_ms,\n"
              "jitter_definition, solve_us_p50, solve_us_p99, solve_us_max, noise_mm,\n"
              "noise_deg, tilt_deg, rate_hz, latency_ms, dropout, seed, filter, smooth,\n"
              "refine, refined_limbs, refined_joints, lower_body_mpjpe_cm, foot_skate_mm,\n"
              "floor_penetration_mm, steps {solved, truth}, largest_ankle_move_mm (the\n"
              "furthest a solved ankle moves in one sample; _truth_mm: the truth's)");
  if (auto exit_code = p.parse(argv)) return exit_code;
  std::tie(st.noise_mm, st.noise_deg) = *parse_noise(o.noise);
  st.seed = static_cast<uint64_t>(o.seed);
  st.max_frames = o.frames;
  st.filter = !o.no_filter;
  st.smooth = !o.no_smooth;
  st.refine = !o.no_refine;
  st.step = !o.no_step;
  return std::nullopt;
}

int run_eval_solver(const std::vector<std::string>& argv) {
  cli::Parser parser(kName, kAbout);
  Options o;
  Settings st;
  if (auto exit_code = parse(parser, argv, o, st)) return *exit_code;
  const std::string* clip_path = &o.clip_path;
  const std::vector<std::string>& layouts = o.layouts;

  auto motion = rig::load_bvh_motion(*clip_path);
  if (!motion) return failure(kName, motion.error().message);
  std::shared_ptr<const rig::Motion> shared(std::move(*motion));
  auto clip = rig::load_bvh(*clip_path);  // for the frame time
  if (!clip) return failure(kName, clip.error().message);
  const std::string name = base_name(*clip_path);
  const bool json = o.json;
  std::ofstream trace;
  if (!o.trace_path.empty()) {
    trace.open(o.trace_path);
    if (!trace) return failure(kName, "cannot write " + o.trace_path);
    trace << "layout,t_s,joint,true_x,true_y,true_z,solved_x,solved_y,solved_z\n";
    st.trace = &trace;
  }
  if (!json) {
    std::printf(
        "clip %s: %.2f s at %.0f Hz; noise %.2f mm / %.2f deg; mounting tilt up to %.0f deg; filter %s; limb "
        "refinement %s; seed %llu\n",
        name.c_str(), shared->duration_s(), st.rate_hz, st.noise_mm, st.noise_deg, st.tilt_deg,
        st.filter ? "on" : "off", st.refine ? "on" : "off", static_cast<unsigned long long>(st.seed));
    std::printf(
        "joint set: every joint but the toes; world space, no alignment. jitter = mean |p[t+1]-2p[t]+p[t-1]|\n");
    std::printf("%-7s %7s %9s %10s %8s %8s %8s %8s %9s %11s %13s %11s %11s\n", "sensors", "frames", "mpjpe_cm",
                "mpjre_deg", "ee_mm", "lower_cm", "skate_mm", "floor_mm", "steps", "jitter_mm", "(truth_mm)",
                "solve_p50", "solve_p99");
  }
  st.stand = calibration_stand(*shared, clip->frame_time_s, st.rate_hz);
  int status = 0;
  for (const auto& layout : layouts) {
    const Run r = evaluate(shared, clip->frame_time_s, layout, st);
    if (!r.error.empty()) {
      std::fprintf(stderr, "mimic %s: %s layout %s: %s\n", kName, name.c_str(), layout.c_str(), r.error.c_str());
      status = 1;
      continue;
    }
    const auto& p = r.report;
    if (json) {
      nlohmann::json j{{"clip", name},
                       {"sensors", layout},
                       {"frames", p.frames},
                       {"joints", p.joints},
                       {"mpjpe_cm", p.mpjpe_cm},
                       {"mpjre_deg", p.mpjre_deg},
                       {"end_effector_mm", p.end_effector_mm},
                       {"end_effector_max_mm", p.end_effector_max_mm},
                       {"end_effector_reach_mm", r.reach_mm},
                       {"lower_body_mpjpe_cm", r.gait.lower_body_mpjpe_cm},
                       {"foot_skate_mm", r.gait.foot_skate_mm},
                       {"floor_penetration_mm", r.gait.floor_penetration_mm},
                       {"largest_ankle_move_mm", r.gait.largest_ankle_move_mm},
                       {"largest_ankle_move_truth_mm", r.gait.largest_ankle_move_truth_mm},
                       {"steps", {{"solved", r.gait.steps_solved}, {"truth", r.gait.steps_truth}}},
                       {"jitter", p.jitter_mm},
                       {"jitter_mm", p.jitter_mm},
                       {"jitter_truth_mm", p.jitter_truth_mm},
                       {"lag_ms", p.lag_ms},
                       {"jitter_definition", "mean |p[t+1]-2p[t]+p[t-1]| of solved joint positions per sample, mm"},
                       {"solve_us_p50", p.solve_us_p50},
                       {"solve_us_p99", p.solve_us_p99},
                       {"solve_us_max", p.solve_us_max},
                       {"noise_mm", st.noise_mm},
                       {"noise_deg", st.noise_deg},
                       {"tilt_deg", st.tilt_deg},
                       {"rate_hz", st.rate_hz},
                       {"latency_ms", st.latency_ms},
                       {"dropout", st.dropout},
                       {"seed", st.seed},
                       {"filter", st.filter},
                       {"smooth", st.filter && st.smooth},
                       {"refine", st.refine},
                       {"step", st.step},
                       {"refined_limbs", r.refined_limbs},
                       {"refined_joints", r.refined_joints}};
      std::printf("%s\n", j.dump().c_str());
    } else {
      const auto& g = r.gait;
      std::printf("%-7s %7d %9.2f %10.1f %8.1f %8.2f %8.1f %8.1f %4d/%-4d %11.2f %13.2f %9.1fus %9.1fus\n",
                  layout.c_str(), p.frames, p.mpjpe_cm, p.mpjre_deg, p.end_effector_mm, g.lower_body_mpjpe_cm,
                  g.foot_skate_mm, g.floor_penetration_mm, g.steps_solved, g.steps_truth, p.jitter_mm,
                  p.jitter_truth_mm, p.solve_us_p50, p.solve_us_p99);
      if (o.joints)
        for (size_t i = 0; i < p.joint_names.size(); ++i)
          std::printf("          %-14s %6.2f cm  jitter %5.2f mm\n", p.joint_names[i].c_str(), p.joint_mpjpe_cm[i],
                      i < p.joint_jitter_mm.size() ? p.joint_jitter_mm[i] : 0.0);
    }
    std::fflush(stdout);
  }
  return status;
}

}  // namespace

MIMIC_COMMAND(eval_solver, "eval-solver", "measure the joint-angle solver on a BVH clip (MPJPE, MPJRE, jitter, time)",
              run_eval_solver);

}  // namespace mimic::app::cmd_eval_solver
