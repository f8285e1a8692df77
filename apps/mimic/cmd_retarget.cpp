// `mimic retarget`: a BVH clip (CMU or Mimic joint names) onto Mimic's skeleton, written back
// as BVH in Mimic's hierarchy with one channel per DOF.
#include <algorithm>
#include <cstdio>
#include <vector>

#include "command.h"
#include "mimic/rig/bvh.h"
#include "mimic/rig/retarget.h"
#include "mimic/core/file.h"

namespace mimic::app {
namespace {

constexpr const char* kName = "retarget";

constexpr const char* kUsage =
    "usage: mimic retarget --bvh IN.bvh --out OUT.bvh [options]\n"
    "\n"
    "Retargets a BVH clip onto Mimic's skeleton, keeping the performer's proportions, and writes\n"
    "it as BVH in Mimic's hierarchy: the root with 6 channels, every other joint one rotation\n"
    "channel per DOF (e.g. l_elbow: flexion, forearm twist). IN may use CMU/cgspeed joint names\n"
    "(Hips, LeftUpLeg, ...) or Mimic's own (a file this command wrote). Prints the clip, the\n"
    "performer's proportions and how closely Mimic's joint centres follow the clip's.\n"
    "\n"
    "options:\n"
    "  --bvh IN.bvh          clip to read (required)\n"
    "  --out OUT.bvh         file to write (required; written atomically)\n"
    "  --scale M            metres per unit of IN (default 0.056444, the CMU unit)\n"
    "  --out-scale M        metres per unit of OUT (default 0.056444, so OUT reads back with\n"
    "                       the default --scale; use 0.01 for centimetres, 1 for metres)\n"
    "  --default-body       write the motion on Mimic's default body instead of the performer's\n"
    "                       (same joint angles, root translation scaled by standing height)\n"
    "  -h, --help           this text\n"
    "\n"
    "exit status: 0 done, 1 unreadable or unsupported clip, 2 usage error\n";

int run_retarget(const std::vector<std::string>& argv) {
  Args args(argv, {"bvh", "out", "scale", "out-scale"}, {"default-body"});
  if (args.help()) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (!args.ok()) return usage_error(kName, args.error());
  if (!args.positionals().empty()) return usage_error(kName, "unexpected argument '" + args.positionals()[0] + "'");
  const auto in = args.get("bvh");
  const auto out = args.get("out");
  if (!in) return usage_error(kName, "--bvh IN.bvh is required");
  if (!out) return usage_error(kName, "--out OUT.bvh is required");
  double scale = rig::kCmuMetresPerUnit, out_scale = rig::kCmuMetresPerUnit;
  if (!args.get_double("scale", scale) || !args.get_double("out-scale", out_scale)) return usage_error(kName, args.error());
  if (!(scale > 0)) return usage_error(kName, "--scale must be a positive number of metres per file unit");
  if (!(out_scale > 0)) return usage_error(kName, "--out-scale must be a positive number of metres per file unit");

  auto clip = rig::load_bvh(*in, rig::BvhParseOptions{scale});
  if (!clip) return failure(kName, clip.error().message);
  std::printf("read %s: %zu joints, %d channels, %d frames at %.2f fps (%.2f s), %.6f m per unit\n", in->c_str(),
              clip->joints.size(), clip->channel_count, clip->frame_count, 1.0 / clip->frame_time_s,
              (clip->frame_count > 0 ? clip->frame_count - 1 : 0) * clip->frame_time_s, scale);
  auto r = rig::retarget_bvh(*clip);
  if (!r) return failure(kName, r.error().message);

  // How well Mimic's joints follow the clip's (they should agree to well under a millimetre).
  double worst = 0, sum = 0;
  long count = 0;
  std::vector<rig::RigidTransform> wm(r->skeleton.joint_count()), wb(clip->joints.size());
  for (int f = 0; f < clip->frame_count; ++f) {
    rig::forward_kinematics(r->skeleton, r->poses[f], wm);
    rig::bvh_forward_kinematics(*clip, f, wb);
    for (int j = 0; j < r->skeleton.joint_count(); ++j) {
      const double d = glm::length(wm[j].translation - wb[r->bvh_joint[j]].translation);
      worst = std::max(worst, d);
      sum += d;
      ++count;
    }
  }
  const rig::Proportions p = rig::measure_proportions(r->skeleton);
  std::printf("retargeted onto %d Mimic joints (%d DOFs): performer pelvis height %.3f m, thigh %.3f m, shin %.3f m, "
              "upper arm %.3f m, forearm %.3f m\n",
              r->skeleton.joint_count(), r->skeleton.dof_count(), p.pelvis_height_m, p.thigh_m, p.shin_m,
              p.upper_arm_m, p.forearm_m);
  std::printf("segments aligned %s\n", r->characterised_on_t_pose ? "on the clip's frame-0 T-pose (head level, feet flat)"
                                                                   : "at the clip's rest pose (frame 0 is no T-pose)");
  std::printf("joint centres vs the clip: mean %.3f mm, max %.3f mm\n", count ? 1000 * sum / static_cast<double>(count) : 0.0, 1000 * worst);

  const rig::Skeleton* skeleton = &r->skeleton;
  std::vector<rig::Pose> poses = std::move(r->poses);
  rig::Skeleton body;
  if (args.has("default-body")) {
    auto b = rig::Skeleton::build(rig::default_skeleton_desc());
    if (!b) return failure(kName, b.error().message);
    body = std::move(*b);
    for (auto& pose : poses) pose = rig::transfer_pose(r->skeleton, pose, body);
    skeleton = &body;
    std::printf("transferred onto the default body (root translation x%.3f)\n",
                rig::standing_root_height_m(body) / rig::standing_root_height_m(r->skeleton));
  }
  auto text = rig::write_bvh(*skeleton, poses, clip->frame_time_s, out_scale);
  if (!text) return failure(kName, text.error().message);
  if (auto s = write_file_atomic(*out, *text); !s) return failure(kName, s.error().message);
  std::printf("wrote %s: %zu frames, %d channels per frame, %.6f m per unit (%zu bytes)\n", out->c_str(), poses.size(),
              6 + skeleton->dof_count(), out_scale, text->size());
  return 0;
}

}  // namespace

MIMIC_COMMAND(retarget, kName, "retarget a BVH clip onto Mimic's skeleton and write it as BVH", kUsage, run_retarget);

}  // namespace mimic::app
