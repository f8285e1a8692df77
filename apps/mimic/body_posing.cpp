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

Result<avatar::BodyModel> body_from_args(const Args& args) {
  if (auto path = args.get("body")) return avatar::load_body_or_preset(*path);
  return avatar::default_body_model();
}

Result<PoseRequest> pose_from_args(const Args& a, const rig::Skeleton& skeleton) {
  Args args = a;
  const auto t0 = std::chrono::steady_clock::now();
  PoseRequest req;
  const int sources = int(args.has("bvh")) + int(args.has("motion")) + int(args.has("pose"));
  if (sources > 1) return fail(Errc::invalid_argument, "give one of --bvh, --motion or --pose");
  if (auto bvh = args.get("bvh")) {
    double scale = rig::kCmuMetresPerUnit;
    long frame = 0;
    if (!args.get_double("scale", scale) || !args.get_int("frame", frame)) return fail(Errc::invalid_argument, args.error());
    if (!(std::isfinite(scale) && scale > 0)) return fail(Errc::invalid_argument, "--scale must be a positive number of metres per unit");
    if (!args.has("frame")) return fail(Errc::invalid_argument, "--bvh needs --frame N (frames count from 0)");
    auto clip = rig::load_bvh(*bvh, rig::BvhParseOptions{scale});
    if (!clip) return tl::unexpected(clip.error());
    if (frame < 0 || frame >= clip->frame_count)
      return fail(Errc::out_of_range, "--frame " + std::to_string(frame) + " is outside " + *bvh + " (frames 0.." +
                                          std::to_string(clip->frame_count - 1) + ")");
    auto r = rig::retarget_bvh(*clip);
    if (!r) return tl::unexpected(r.error());
    req.pose = rig::transfer_pose(r->skeleton, r->poses[frame], skeleton);
    req.description = *bvh + " frame " + std::to_string(frame) + " of " + std::to_string(clip->frame_count);
  } else if (auto motion = args.get("motion")) {
    double time_s = 0;
    if (!args.get_double("time", time_s)) return fail(Errc::invalid_argument, args.error());
    // strtod takes "nan" and "inf"; a motion has no pose there (and loops far from 1e9 s).
    if (!(time_s >= 0 && time_s <= kMaxTime_s))
      return fail(Errc::invalid_argument, "--time must be 0.." + std::to_string(int(kMaxTime_s)) + " seconds, got '" +
                                              args.get_or("time", "") + "'");
    auto m = rig::make_builtin_motion(*motion, skeleton);
    if (!m) return tl::unexpected(m.error());
    req.pose = skeleton.zero_pose();
    (*m)->sample(time_s, req.pose);
    req.description = "built-in motion '" + *motion + "' at " + std::to_string(time_s) + " s";
  } else {
    const std::string which = args.get_or("pose", "zero");
    if (which == "zero") req.pose = skeleton.zero_pose();
    else if (which == "rest") req.pose = avatar::relaxed_posture(skeleton);
    else return fail(Errc::invalid_argument, "--pose must be zero or rest, got '" + which + "'");
    req.pose.root_position_m.y = rig::standing_root_height_m(skeleton);
    req.description = which + " posture";
  }
  req.load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return req;
}

}  // namespace mimic::app
