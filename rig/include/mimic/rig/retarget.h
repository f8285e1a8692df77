// Retargeting BVH clips onto Mimic's skeleton, keeping the performer's proportions.
//
// Two joint-name conventions are understood:
//  - CMU / cgspeed MotionBuilder-friendly: Hips→pelvis, LowerBack→spine_lower, Spine→spine_mid,
//    Spine1→spine_upper, Neck→neck, Neck1→neck_upper, Head→head, LeftShoulder→l_clavicle,
//    LeftArm→l_shoulder, LeftForeArm→l_elbow, LeftHand→l_wrist, LeftUpLeg→l_hip,
//    LeftLeg→l_knee, LeftFoot→l_ankle, LeftToeBase→l_toes (Right* alike). LHipJoint,
//    RHipJoint, fingers and thumbs are ignored.
//  - Mimic's own names (a clip written by write_bvh): every joint maps to itself.
//
// Method. Each Mimic segment m gets a constant alignment A_m, chosen so that where the clip
// shows its T-pose Mimic's segments take their own T-pose orientations. A CMU clip whose frame 0
// is a T-pose (upper arms within 30° of level, thighs within 20° of vertical: the
// MotionBuilder-friendly conversions) is characterised on that frame: limbs and spine turned by
// the shortest arc onto the performer's links there, head level and feet flat, all from the
// performer's heading. Other CMU clips align at the rest pose (all channels zero): A_m takes
// Mimic's rest link direction onto the clip's rest link direction. A clip in Mimic's own names
// needs no alignment (its rest pose is Mimic's zero posture). The fitted skeleton's offsets
// are the clip's bone vectors expressed in Mimic's frames (offset_m = A_parent⁻¹ · bone), so
// Mimic's segment world rotation G_m = G_bvh · A_m reproduces the clip's joint positions
// whatever A_m is. Per frame, each joint's local rotation G_actual(parent)⁻¹ · G_m is turned
// into DOF values (joint_angles.h), always from the parent rotation the produced DOFs actually
// give, so errors never accumulate.
// Joints with fewer than three DOFs are solved so positions stay exact: clavicles aim their
// link at the shoulder; shoulder(3) + elbow flexion and hip(3) + knee flexion are solved as
// two-bone chains (elbow/knee and wrist/ankle on the clip's positions, the hinge side taken
// from the clip's upper segment), then forearm twist + wrist(2), and the ankle(3), take the
// end segment's orientation. Limits are not applied (clamp_to_limits does that if wanted).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "mimic/rig/bvh.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::rig {

struct RetargetedClip {
  Skeleton skeleton;        // Mimic's joints and DOFs, offsets fitted to the performer (metres)
  std::vector<Pose> poses;  // one per clip frame (frame 0 of a CMU clip is its T-pose)
  double frame_time_s = 0;
  std::vector<int> bvh_joint;  // per Mimic joint: the clip joint it follows
  std::string source_name;
  bool characterised_on_t_pose = false;  // frame 0 was the T-pose the segments are aligned on
};

// Fails (Errc::unsupported) when the clip uses neither naming convention, naming the first
// missing joint; Errc::invalid_argument for a clip without frames.
Result<RetargetedClip> retarget_bvh(const BvhClip& clip);

// The same joint angles on another skeleton (DOFs matched by name; DOFs `to` has and `from`
// lacks take their rest value). The root translation is scaled by the ratio of standing root
// heights, so a performer's clip drives a body of another size without floating or sinking.
Pose transfer_pose(const Skeleton& from, const Pose& pose, const Skeleton& to);

struct BvhMotionOptions {
  double metres_per_unit = kCmuMetresPerUnit;
  // When set, the clip drives this body (copied) through transfer_pose instead of the
  // performer's fitted skeleton.
  const Skeleton* body = nullptr;
};

// A Motion over a retargeted clip: time t is frame t / frame_time (frame 0 at t = 0, the
// T-pose for CMU clips), DOFs interpolated linearly between frames, root orientation by slerp.
// Does not loop; duration = (frames − 1) · frame_time. The Motion's name is the clip's path.
Result<std::unique_ptr<Motion>> load_bvh_motion(const std::string& path, const BvhMotionOptions& options = {});
std::unique_ptr<Motion> make_clip_motion(RetargetedClip clip);

}  // namespace mimic::rig
