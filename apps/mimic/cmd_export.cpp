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
#include "cli.h"
#include "command.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/gltf_animation.h"
#include "mimic/rig/motion.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/rig/retarget.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/vrm.h"
#include "mimic/core/file.h"
#include "mimic/service/solve_log.h"

namespace mimic::app::cmd_export {
namespace {

constexpr const char* kName = "export";
constexpr const char* kAbout =
    "Writes a rigged, animated glTF 2.0 binary of the avatar: the skin in the bind pose (the\n"
    "zero posture, a T-pose) with the realtime method's topology (contour points are the\n"
    "vertices), a skin with the skeleton's joints as a node hierarchy and their inverse bind\n"
    "matrices, up to four joint weights per vertex derived from the contours, and the motion as\n"
    "one animation (root translation, joint rotations, linear keys). glTF players (three.js,\n"
    "Blender, the Khronos validator) play it without Mimic. --vrm writes the same body as a\n"
    "VRM 1.0 avatar (humanoid bones, meta, no animation) for VRM apps (three-vrm, VSeeFace).";

struct Options {
  std::string bvh, motion, log, calibration, body, out, vrm;
  std::vector<std::string> authors;
  double fps = 30, seconds = 0;
  int lod = 0;
};

// One of --bvh, --motion or --log for --out; --vrm alone needs none (the body's skeleton).
std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  auto& app = p.app();
  auto* bvh =
      app.add_option("--bvh", o.bvh, "a BVH clip (CMU units), retargeted onto the body's skeleton")->type_name("CLIP");
  auto* motion = app.add_option("--motion", o.motion, "a built-in motion (one loop)")
                     ->check(CLI::IsMember(rig::builtin_motion_names()));
  auto* log = app.add_option("--log", o.log,
                             "a recorded tracker session (mimic record), solved frame by frame as\n"
                             "mimic run --source replay: would (filters, body solver), at --fps")
                  ->type_name("SESSION.mlog");
  app.add_option("--calibration", o.calibration,
                 "the wearer's calibration (mimic calibrate) for --log: the animation is\non their fitted skeleton")
      ->type_name("FILE")
      ->needs(log);
  bvh->excludes(motion)->excludes(log);
  motion->excludes(log);
  app.add_option("--body", o.body, "body model or preset:NAME (default: the built-in body)")->type_name("FILE");
  app.add_option("--fps", o.fps, "keyframes per second")->check(cli::finite_range(0, 240, cli::Bound::exclusive));
  app.add_option("--seconds", o.seconds, "at most S seconds of the motion (default: all of it)")
      ->check(cli::finite_range(0, INFINITY));
  app.add_option("--lod", o.lod, "skin level of detail, 0 finest")->check(CLI::Range(0, avatar::kSkinLodCount - 1));
  auto* out = app.add_option("--out", o.out, "the animated .glb to write")->type_name("FILE");
  auto* vrm = app.add_option("--vrm", o.vrm,
                             "a VRM 1.0 avatar to write (the body in its T-pose, on --log's fitted\n"
                             "skeleton when --calibration is given)")
                  ->type_name("FILE.vrm");
  app.add_option("--author", o.authors, "the VRM's author (repeatable; default: Mimic)")->type_name("NAME")->needs(vrm);
  if (auto exit_code = p.parse(argv)) return exit_code;
  if (out->count() + vrm->count() == 0) return p.usage_error("give --out FILE.glb, --vrm FILE.vrm or both");
  const size_t sources = bvh->count() + motion->count() + log->count();
  if (sources > 1 || (sources == 0 && out->count() > 0))
    return p.usage_error("give one of --bvh CLIP, --motion NAME or --log SESSION.mlog");
  return std::nullopt;
}

// The animation's keys: a motion sampled every 1/fps and once at its very end.
void sample_motion(const rig::Motion& motion, const Options& o, avatar::SkinnedAnimation& anim) {
  const double span_s = o.seconds > 0 ? std::min(o.seconds, motion.duration_s()) : motion.duration_s();
  // A clip whose length is not a whole number of key intervals (a BVH's frame time is rounded:
  // 0.008333 s) keeps its last frame.
  const long keys = std::max(2L, static_cast<long>(std::ceil(span_s * o.fps - 1e-6)) + 1);
  rig::Pose pose = motion.skeleton().zero_pose();
  for (long k = 0; k < keys; ++k) {
    const double t = std::min(span_s, double(k) / o.fps);
    if (k > 0 && !(t > anim.times_s.back())) break;
    motion.sample(t, pose);
    anim.times_s.push_back(t);
    anim.poses.push_back(pose);
  }
}

int write_vrm(const Options& o, const avatar::BodyModel& body, const avatar::SkinnedAnimation& anim) {
  avatar::VrmMeta meta;
  meta.name = body.name;
  if (!o.authors.empty()) meta.authors = o.authors;
  meta.version = "Mimic, " + std::to_string(anim.bind_mesh->positions.size()) + " vertices";
  auto bytes = avatar::encode_vrm(anim, meta);
  if (!bytes) return failure(kName, bytes.error().what());
  if (auto st = write_file_atomic(o.vrm, *bytes); !st) return failure(kName, st.error().what());
  std::printf("%s: VRM 1.0, %zu vertices, %zu triangles, %zu humanoid bones of %d joints; %zu bytes\n", o.vrm.c_str(),
              anim.bind_mesh->positions.size(), anim.bind_mesh->triangle_count(),
              avatar::vrm_humanoid_bones(*anim.skeleton).size(), anim.skeleton->joint_count(), bytes->size());
  return 0;
}

int write_glb(const Options& o, const avatar::SkinnedAnimation& anim, const std::string& what) {
  auto bytes = avatar::encode_skinned_glb(anim);
  if (!bytes) return failure(kName, bytes.error().what());
  if (auto st = write_file_atomic(o.out, *bytes); !st) return failure(kName, st.error().what());
  size_t influenced = 0;
  for (const auto& in : anim.influences)
    influenced = std::max<size_t>(
        influenced, size_t(std::count_if(in.weight.begin(), in.weight.end(), [](float w) { return w > 0; })));
  std::printf(
      "%s: %zu vertices, %zu triangles, %d joints, up to %zu influences per vertex; %zu keyframes over %.2f s "
      "(%s); %zu bytes\n",
      o.out.c_str(), anim.bind_mesh->positions.size(), anim.bind_mesh->triangle_count(), anim.skeleton->joint_count(),
      influenced, anim.times_s.size(), anim.times_s.back(), what.c_str(), bytes->size());
  return 0;
}

int run(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  auto body = body_from_path(o.body);
  if (!body) return failure(kName, body.error().what());
  auto skeleton = rig::Skeleton::build(body->skeleton);
  if (!skeleton) return failure(kName, skeleton.error().what());
  // The animation's skeleton and keys: a motion sampled at --fps, or a recorded session solved
  // at --fps (on the calibration's fitted skeleton when one is given).
  std::unique_ptr<rig::Motion> motion;
  std::optional<service::SolvedTake> take;
  if (!o.bvh.empty()) {
    rig::BvhMotionOptions bo;
    bo.body = &*skeleton;
    auto m = rig::load_bvh_motion(o.bvh, bo);
    if (!m) return failure(kName, m.error().what());
    motion = std::move(*m);
  } else if (!o.motion.empty()) {
    auto m = rig::make_builtin_motion(o.motion, *skeleton);
    if (!m) return usage_error(kName, m.error().message);
    motion = std::move(*m);
  } else if (!o.log.empty()) {
    auto t = service::solve_log(o.log, o.calibration, o.fps, &*skeleton, o.seconds);
    if (!t) return failure(kName, t.error().what());
    if (t->poses.size() < 2) return failure(kName, o.log + ": too short for an animation (under two frames)");
    take = std::move(*t);
  }
  const rig::Skeleton& sk = motion ? motion->skeleton() : take ? take->skeleton : *skeleton;

  avatar::RealtimeOptions ro;
  ro.lod = o.lod;
  auto shared = avatar::RealtimeBody::create(*body, sk, ro);
  if (!shared) return failure(kName, shared.error().what());

  avatar::SkinnedAnimation anim;
  anim.bind_mesh = &(*shared)->rest_mesh();
  anim.influences = (*shared)->weights();
  anim.skeleton = &sk;
  anim.bind_pose = ro.initial_pose ? *ro.initial_pose : sk.zero_pose();
  anim.name = body->name;
  if (!o.vrm.empty())
    if (const int st = write_vrm(o, *body, anim); st != 0) return st;
  if (o.out.empty()) return 0;
  std::string what;
  if (motion) {
    sample_motion(*motion, o, anim);
    what = motion->name();
  } else {
    anim.times_s = std::move(take->times_s);
    anim.poses = std::move(take->poses);
    what = take->description + ", " + std::to_string(take->samples) + " samples solved";
  }
  return write_glb(o, anim, what);
}

}  // namespace

MIMIC_COMMAND(export_, kName,
              "write a rigged, animated glTF (.glb) of the avatar on a BVH clip, a motion or a recorded session, or a "
              "VRM 1.0 avatar",
              run);

}  // namespace mimic::app::cmd_export
