// mimic export: a rigged, animated glTF of the avatar (bind mesh, skin, joint hierarchy,
// contour-derived weights, the motion as an animation).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "body_posing.h"
#include "command.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/gltf_animation.h"
#include "mimic/rig/motion.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/rig/retarget.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/core/file.h"
#include "mimic/service/solve_log.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "export";
constexpr const char* kUsage =
    "usage: mimic export (--bvh CLIP | --motion NAME | --log SESSION.mlog [--calibration C])\n"
    "                    [--body FILE] [--fps F] [--seconds S] [--lod N] --out anim.glb\n"
    "\n"
    "Writes a rigged, animated glTF 2.0 binary of the avatar: the skin in the bind pose (the\n"
    "zero posture, a T-pose) with the realtime method's topology (contour points are the\n"
    "vertices), a skin with the skeleton's joints as a node hierarchy and their inverse bind\n"
    "matrices, up to four joint weights per vertex derived from the contours, and the motion as\n"
    "one animation (root translation, joint rotations, linear keys). glTF players (three.js,\n"
    "Blender, the Khronos validator) play it without Mimic.\n"
    "\n"
    "options:\n"
    "  --bvh CLIP      a BVH clip (CMU units), retargeted onto the body's skeleton\n"
    "  --motion NAME   a built-in motion: idle, walk (one loop)\n"
    "  --log FILE      a recorded tracker session (mimic record), solved frame by frame as\n"
    "                  mimic run --source replay: would (filters, body solver), at --fps\n"
    "  --calibration C the wearer's calibration (mimic calibrate) for --log: the animation is\n"
    "                  on their fitted skeleton\n"
    "  --body FILE     body model or preset:NAME (default: the built-in body)\n"
    "  --fps F         keyframes per second (default 30)\n"
    "  --seconds S     at most S seconds of the motion (default: all of it)\n"
    "  --lod N         skin level of detail, 0 finest (default 0)\n"
    "  --out FILE      the .glb to write\n";

int run(const std::vector<std::string>& argv) {
  Args args(argv, {"bvh", "motion", "log", "calibration", "body", "fps", "seconds", "lod", "out"}, {});
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  if (int(args.has("bvh")) + int(args.has("motion")) + int(args.has("log")) != 1)
    return usage_error(kName, "give one of --bvh CLIP, --motion NAME or --log SESSION.mlog");
  if (args.has("calibration") && !args.has("log")) return usage_error(kName, "--calibration goes with --log");
  if (!args.has("out")) return usage_error(kName, "--out FILE is required");
  double fps = 30, seconds = 0;
  long lod = 0;
  if (!args.get_double("fps", fps) || !args.get_double("seconds", seconds) || !args.get_int("lod", lod))
    return usage_error(kName, args.error());
  if (!(fps > 0 && fps <= 240)) return usage_error(kName, "--fps must be in (0, 240]");
  if (!(seconds >= 0 && std::isfinite(seconds))) return usage_error(kName, "--seconds must be a number >= 0");
  if (lod < 0 || lod >= avatar::kSkinLodCount)
    return usage_error(kName, "--lod must be 0.." + std::to_string(avatar::kSkinLodCount - 1) + ", got " + std::to_string(lod));

  auto body = body_from_args(args);
  if (!body) return failure(kName, body.error().what());
  auto skeleton = rig::Skeleton::build(body->skeleton);
  if (!skeleton) return failure(kName, skeleton.error().what());
  // The animation's skeleton and keys: a motion sampled at --fps, or a recorded session solved
  // at --fps (on the calibration's fitted skeleton when one is given).
  std::unique_ptr<rig::Motion> motion;
  std::optional<service::SolvedTake> take;
  if (args.has("bvh")) {
    rig::BvhMotionOptions o;
    o.body = &*skeleton;
    auto m = rig::load_bvh_motion(*args.get("bvh"), o);
    if (!m) return failure(kName, m.error().what());
    motion = std::move(*m);
  } else if (args.has("motion")) {
    auto m = rig::make_builtin_motion(*args.get("motion"), *skeleton);
    if (!m) return usage_error(kName, m.error().message);
    motion = std::move(*m);
  } else {
    auto t = service::solve_log(*args.get("log"), args.get_or("calibration", ""), fps, &*skeleton, seconds);
    if (!t) return failure(kName, t.error().what());
    if (t->poses.size() < 2) return failure(kName, *args.get("log") + ": too short for an animation (under two frames)");
    take = std::move(*t);
  }
  const rig::Skeleton& sk = motion ? motion->skeleton() : take->skeleton;

  avatar::RealtimeOptions ro;
  ro.lod = static_cast<int>(lod);
  auto shared = avatar::RealtimeBody::create(*body, sk, ro);
  if (!shared) return failure(kName, shared.error().what());

  avatar::SkinnedAnimation anim;
  anim.bind_mesh = &(*shared)->rest_mesh();
  anim.influences = (*shared)->weights();
  anim.skeleton = &sk;
  anim.bind_pose = ro.initial_pose ? *ro.initial_pose : sk.zero_pose();
  anim.name = body->name;
  std::string what;
  if (motion) {
    const double span_s = seconds > 0 ? std::min(seconds, motion->duration_s()) : motion->duration_s();
    // Keys every 1/fps and one at the very end: a clip whose length is not a whole number of
    // key intervals (a BVH's frame time is rounded: 0.008333 s) keeps its last frame.
    const long keys = std::max(2L, static_cast<long>(std::ceil(span_s * fps - 1e-6)) + 1);
    rig::Pose pose = sk.zero_pose();
    for (long k = 0; k < keys; ++k) {
      const double t = std::min(span_s, double(k) / fps);
      if (k > 0 && !(t > anim.times_s.back())) break;
      motion->sample(t, pose);
      anim.times_s.push_back(t);
      anim.poses.push_back(pose);
    }
    what = motion->name();
  } else {
    anim.times_s = std::move(take->times_s);
    anim.poses = std::move(take->poses);
    what = take->description + ", " + std::to_string(take->samples) + " samples solved";
  }
  auto bytes = avatar::encode_skinned_glb(anim);
  if (!bytes) return failure(kName, bytes.error().what());
  if (auto st = write_file_atomic(*args.get("out"), *bytes); !st) return failure(kName, st.error().what());
  size_t influenced = 0;
  for (const auto& in : anim.influences) influenced = std::max<size_t>(influenced, size_t(std::count_if(in.weight.begin(), in.weight.end(), [](float w) { return w > 0; })));
  std::printf("%s: %zu vertices, %zu triangles, %d joints, up to %zu influences per vertex; %zu keyframes over %.2f s "
              "(%s); %zu bytes\n",
              args.get("out")->c_str(), anim.bind_mesh->positions.size(), anim.bind_mesh->triangle_count(),
              sk.joint_count(), influenced, anim.times_s.size(), anim.times_s.back(), what.c_str(),
              bytes->size());
  return 0;
}

}  // namespace

MIMIC_COMMAND(export_, kName, "write a rigged, animated glTF (.glb) of the avatar on a BVH clip, a motion or a recorded session", kUsage, run);

}  // namespace mimic::app
