#include "body_posing.h"

#include <chrono>
#include <cmath>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/body_presets.h"
#include "mimic/rig/bvh.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/retarget.h"

namespace mimic::app {

namespace {
constexpr double kMaxTime_s = 3600;  // an hour of a looping motion is plenty
}  // namespace

Result<avatar::BodyModel> body_from_path(const std::string& path) {
  if (!path.empty()) return avatar::load_body_or_preset(path);
  return avatar::default_body_model();
}

namespace {

// "l_shoulder_abduction=2.5,r_elbow_flexion=1" onto the pose; errors name the DOF.
Status apply_dof_settings(const std::string& list, const rig::Skeleton& skeleton, rig::Pose& pose) {
  size_t start = 0;
  while (start < list.size()) {
    size_t comma = list.find(',', start);
    if (comma == std::string::npos) comma = list.size();
    const std::string item = list.substr(start, comma - start);
    const size_t eq = item.find('=');
    if (eq == std::string::npos) return fail(Errc::invalid_argument, "--set wants DOF=RADIANS, got '" + item + "'");
    const std::string name = item.substr(0, eq);
    const int dof = skeleton.find_dof(name);
    if (dof < 0) return fail(Errc::invalid_argument, "--set: the skeleton has no DOF '" + name + "'");
    // The whole value, and finite: "1.2x", "nan" and "inf" are no angles.
    const std::string value = item.substr(eq + 1);
    size_t used = 0;
    float rad = NAN;
    try {
      rad = std::stof(value, &used);
    } catch (...) {}
    if (used != value.size() || !std::isfinite(rad))
      return fail(Errc::invalid_argument, "--set: '" + value + "' is not a number");
    pose.dof_rad[dof] = rad;
    start = comma + 1;
  }
  return {};
}

}  // namespace

void add_pose_options(CLI::App& app, PoseOptions& o) {
  auto* bvh = app.add_option("--bvh", o.bvh,
                             "pose: frame --frame N of a BVH clip (frames count from 0, the clip's first\n"
                             "frame; CMU clips start with a T-pose), retargeted onto the body")
                  ->type_name("CLIP");
  app.add_option("--frame", o.frame, "the --bvh clip's frame")
      ->default_str("")
      ->check(CLI::NonNegativeNumber)
      ->needs(bvh);
  app.add_option("--scale", o.scale, "metres per BVH unit (default 0.056444, the CMU unit)")
      ->default_str("")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive))
      ->needs(bvh);
  auto* motion = app.add_option("--motion", o.motion, "pose: a built-in motion at --time S")
                     ->check(CLI::IsMember(rig::builtin_motion_names()))
                     ->excludes(bvh);
  app.add_option("--time", o.time_s, "seconds into the --motion")
      ->check(cli::finite_range(0, kMaxTime_s))
      ->needs(motion);
  app.add_option("--pose", o.pose, "pose: the T-pose the body is authored in, or the relaxed posture\n(default zero)")
      ->check(CLI::IsMember({"zero", "rest"}))
      ->excludes(bvh)
      ->excludes(motion);
  app.add_option("--set", o.set, "then set these joint DOFs (radians), e.g. l_shoulder_abduction=2.5")
      ->type_name("DOF=RAD,...");
}

Result<PoseRequest> pose_from(const PoseOptions& o, const rig::Skeleton& skeleton) {
  const auto t0 = std::chrono::steady_clock::now();
  PoseRequest req;
  if (!o.bvh.empty()) {
    if (o.frame < 0) return fail(Errc::invalid_argument, "--bvh needs --frame N (frames count from 0)");
    auto clip = rig::load_bvh(o.bvh, rig::BvhParseOptions{o.scale > 0 ? o.scale : rig::kCmuMetresPerUnit});
    if (!clip) return tl::unexpected(clip.error());
    if (o.frame >= clip->frame_count)
      return fail(Errc::out_of_range, "--frame " + std::to_string(o.frame) + " is outside " + o.bvh + " (frames 0.." +
                                          std::to_string(clip->frame_count - 1) + ")");
    auto r = rig::retarget_bvh(*clip);
    if (!r) return tl::unexpected(r.error());
    req.pose = rig::transfer_pose(r->skeleton, r->poses[size_t(o.frame)], skeleton);
    req.description = o.bvh + " frame " + std::to_string(o.frame) + " of " + std::to_string(clip->frame_count);
  } else if (!o.motion.empty()) {
    auto m = rig::make_builtin_motion(o.motion, skeleton);
    if (!m) return tl::unexpected(m.error());
    req.pose = skeleton.zero_pose();
    (*m)->sample(o.time_s, req.pose);
    req.description = "built-in motion '" + o.motion + "' at " + std::to_string(o.time_s) + " s";
  } else {
    const std::string which = o.pose.empty() ? "zero" : o.pose;
    if (which == "zero")
      req.pose = skeleton.zero_pose();
    else if (which == "rest")
      req.pose = avatar::relaxed_posture(skeleton);
    else
      return fail(Errc::invalid_argument, "--pose must be zero or rest, got '" + which + "'");
    req.pose.root_position_m.y = rig::standing_root_height_m(skeleton);
    req.description = which + " posture";
  }
  if (!o.set.empty()) {
    if (auto s = apply_dof_settings(o.set, skeleton, req.pose); !s) return tl::unexpected(s.error());
    req.description += ", " + o.set;
  }
  req.load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return req;
}

}  // namespace mimic::app
