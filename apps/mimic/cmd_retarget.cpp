// `mimic retarget`: a BVH clip (CMU or Mimic joint names) onto Mimic's skeleton, written back
// as BVH in Mimic's hierarchy with one channel per DOF.
#include <algorithm>
#include <cstdio>
#include <vector>

#include "cli.h"
#include "command.h"
#include "mimic/rig/bvh.h"
#include "mimic/rig/retarget.h"
#include "mimic/core/file.h"

namespace mimic::app::cmd_retarget {
namespace {

constexpr const char* kName = "retarget";

constexpr const char* kAbout =
    "Retargets a BVH clip onto Mimic's skeleton, keeping the performer's proportions, and writes\n"
    "it as BVH in Mimic's hierarchy: the root with 6 channels, every other joint one rotation\n"
    "channel per DOF (e.g. l_elbow: flexion, forearm twist). IN may use CMU/cgspeed joint names\n"
    "(Hips, LeftUpLeg, ...) or Mimic's own (a file this command wrote). Prints the clip, the\n"
    "performer's proportions and how closely Mimic's joint centres follow the clip's.";

int run_retarget(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer("exit status: 0 done, 1 unreadable or unsupported clip, 2 usage error");
  std::string in_path, out_path;
  double scale = rig::kCmuMetresPerUnit, out_scale = rig::kCmuMetresPerUnit;
  bool default_body = false;
  p->add_option("--bvh", in_path, "clip to read")->type_name("IN.bvh")->required();
  p->add_option("--out", out_path, "file to write (written atomically)")->type_name("OUT.bvh")->required();
  p->add_option("--scale", scale, "metres per unit of IN (the CMU unit by default)")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_option("--out-scale", out_scale,
                "metres per unit of OUT (by default the CMU unit, so OUT reads back with\n"
                "the default --scale; use 0.01 for centimetres, 1 for metres)")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
  p->add_flag("--default-body", default_body,
              "write the motion on Mimic's default body instead of the performer's\n"
              "(same joint angles, root translation scaled by standing height)");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  const std::string* in = &in_path;
  const std::string* out = &out_path;

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
  const rig::Proportions props = rig::measure_proportions(r->skeleton);
  std::printf(
      "retargeted onto %d Mimic joints (%d DOFs): performer pelvis height %.3f m, thigh %.3f m, shin %.3f m, "
      "upper arm %.3f m, forearm %.3f m\n",
      r->skeleton.joint_count(), r->skeleton.dof_count(), props.pelvis_height_m, props.thigh_m, props.shin_m,
      props.upper_arm_m, props.forearm_m);
  std::printf("segments aligned %s\n", r->characterised_on_t_pose
                                           ? "on the clip's frame-0 T-pose (head level, feet flat)"
                                           : "at the clip's rest pose (frame 0 is no T-pose)");
  std::printf("joint centres vs the clip: mean %.3f mm, max %.3f mm\n",
              count ? 1000 * sum / static_cast<double>(count) : 0.0, 1000 * worst);

  const rig::Skeleton* skeleton = &r->skeleton;
  std::vector<rig::Pose> poses = std::move(r->poses);
  rig::Skeleton body;
  if (default_body) {
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

MIMIC_COMMAND(retarget, kName, "retarget a BVH clip onto Mimic's skeleton and write it as BVH", run_retarget);

}  // namespace mimic::app::cmd_retarget
