// Whole-body solve: sensor samples → Pose of Mimic's skeleton, for any sensor layout from three
// sensors (head, hands) to one per segment.
//
// Each valid sample gives its segment's world pose through the calibrated mounting offset
// (world_from_segment = reference_from_sensor · sensor_from_segment; the tracker's reference
// frame is taken as Mimic's world). Per frame:
//   1. root: the pelvis segment's pose when it has a sensor; otherwise the root is an unknown of
//      step 2, held upright towards the head's heading (and towards the feet when they have
//      sensors);
//   2. trunk: a damped least-squares solve (warm-started from the pose passed in, joint limits
//      honoured, pulled towards the relaxed posture) of spine, neck and head DOFs to every
//      trunk segment's position and orientation;
//   3. arms and legs: analytic two-bone chains shoulder–elbow–wrist and hip–knee–ankle reaching
//      for the hand/foot segment, the swivel taken from the upper-arm/thigh or forearm/shin
//      sensor when present, else from the hand/foot orientation; the hand/foot orientation then
//      sets forearm twist and wrist, or the ankle;
//   4. any other segment with a sensor (clavicle, toes, …) takes its orientation; joints nothing
//      observes return to their relaxed values.
// Legs nobody tracks (head and hands only, or a foot sensor lost) step (locomotion.h): their feet
// are planted and swung by the stepper, whose state lives in the SolverContext.
// DOFs come from rotations by swing–twist/Euler decomposition without flips (swing_twist.h) and
// are clamped to their limits.
//
// Ozz-style: SolverModel is immutable (built at setup), SolverContext is the caller-owned scratch
// (built at setup for one model), SolveJob::Run() never allocates or throws.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/devices/sample.h"
#include "mimic/solver/least_squares_ik.h"
#include "mimic/solver/locomotion.h"

namespace mimic::solver {

struct SensorMount {
  uint16_t sensor = 0;                      // SensorSample::sensor
  std::string segment;                      // skeleton joint carrying the sensor
  rig::RigidTransform segment_from_sensor;  // where the sensor sits on the segment
};

struct SolverOptions {
  float position_weight = 100.0f;  // least-squares residual weight per metre
  float rotation_weight = 10.0f;   // per radian
  float prior_weight = 0.3f;       // pull of the trunk towards the relaxed posture, per radian
  // … with a pelvis sensor: the trunk then hangs between two sensors, whose noise a loose spine
  // amplifies (6 sensors, 07_01: jitter 5.9 → 4.6 mm, MPJPE 1.60 → 1.56 cm). Stiffer (3) shook
  // less (3.6 mm) but left the head and hands of poses far from upright off their sensors;
  // without a pelvis sensor a stiff spine cannot lean to the head and the hips go astray.
  float prior_weight_with_pelvis = 1.0f;
  float damping = 0.05f;  // Levenberg–Marquardt λ
  int iterations = 4;     // least-squares steps per frame at most (warm starts carry on)
  // … and from the second on, none once a step gained what the linear model promised to within
  // this fraction of the objective left (LeastSquaresIkJob::model_tolerance; docs/solver.md).
  float model_tolerance = 0.01f;
  // Root height of the wearer standing (world y, from calibration; NaN = unknown). With neither
  // pelvis nor foot sensors the root is held near it — a body bends at spine and hips rather
  // than sinking with its head — unless the head comes down while staying upright (a squat, a
  // seat): then the root comes down with it, less `crouch_allowance_m`.
  float standing_root_y_m = std::numeric_limits<float>::quiet_NaN();
  float standing_weight = 3.0f;  // per metre: a gentle pull
  // Legs nobody tracks hang under the hips with the knees soft rather than locked, feet facing
  // the heading and never below the floor, and the root is held that much below the
  // locked-knee height of the stand-still (people in motion rarely lock their knees).
  float relaxed_knee_bend_rad = 0.17f;  // 10°
  float relaxed_root_drop_m = 0.02f;
  float crouch_allowance_m = 0.10f;
  // With head and hands only, the hips may be pulled (per metre; 0: only their height is) to
  // where an upright trunk hanging from the head puts them, tilted by `lean_follow` of the
  // head's own tilt. Off: on the shared clips it took a walk (07_01) from 7.6 to 6.8 cm but
  // the clips whose trunk bends (punches, a dance) lost 1–4 cm.
  float root_follow_weight = 0.0f;
  float lean_follow = 0.0f;
  // … and while walking with swinging arms (a gait the arms' beat times, 0.8–2.2 m/s, fading in
  // over 0.4 m/s at either end, once it has lasted 0.3 s) they are (per metre; 0: off), the trunk
  // leaning `walk_lean_follow` of the head's tilt, the point smoothed over `walk_follow_tau_s` and
  // led by the pelvis' velocity times that. A walker's posture is in the head's tilt: 07_01's
  // walker holds the head 9° back of upright and the trunk 3° back, 06_04's dribbler 13° and 10°
  // forward; the trunk's solve, left to itself, leaned both 4–6° forward (07_01's hips 8 cm
  // behind the truth's). Timed by the head's bob alone, the hips so pulled outran the beat (the
  // built-in walk stepped twice with a foot 3 times in 15 steps against once).
  float walk_root_follow_weight = 3.0f;
  float walk_lean_follow = 0.5f;
  float walk_follow_tau_s = 0.05f;
  // With head and hands only, the hips' heading turns `hands_heading_share` of the way from the
  // head's to the hands' line across the body (held over `hands_heading_tau_s`) where the two
  // disagree by more than `hands_heading_from_rad`, fully past that plus `hands_heading_over_rad`
  // (0: the head's alone). Eight clips, seeds 1–3 / 4–6: MPJPE 7.15 / 7.29 → 6.99 / 7.09 cm
  // (docs/solver.md, "The hips between a looking head and the hands").
  float hands_heading_share = 0.7f;
  float hands_heading_tau_s = 1.0f;
  float hands_heading_from_rad = 0.52f;  // 30°
  float hands_heading_over_rad = 0.26f;  // 15°
  float locomotion_reach = 0.97f;        // hips no higher than this much of a straight leg above a planted foot
  // Legs nobody tracks (no sensor on thigh, shin or foot, or the foot's sensor lost) step.
  bool step = true;
  LocomotionOptions locomotion;
};

class SolverContext;

class SolverModel {
 public:
  // Fails on a skeleton without Mimic's joint names (pelvis, spine, limbs), a mount on an
  // unknown segment or two mounts with one sensor id.
  static Result<SolverModel> create(rig::Skeleton skeleton, std::vector<SensorMount> mounts,
                                    SolverOptions options = {});

  const rig::Skeleton& skeleton() const { return skeleton_; }
  std::span<const SensorMount> mounts() const { return mounts_; }
  const SolverOptions& options() const { return options_; }

  struct Chain {  // shoulder–elbow–wrist or hip–knee–ankle
    int upper = -1, mid = -1, end = -1;
    int flex_dof = -1;  // the middle joint's first DOF: its bend
    std::array<int, 3> upper_dofs{};
    int upper_dof_count = 0;
    std::array<int, 3> end_dofs{};  // DOFs after the bend that orient the end segment
    int end_dof_count = 0;
    glm::vec3 upper_dir{0};  // unit upper link in the upper joint's frame
    glm::vec3 bend_dir{0};   // where the lower link swings when the bend grows (upper frame)
    glm::vec3 hinge{0};      // bend axis (upper frame); (upper_dir, bend_dir, hinge) right-handed
    float upper_m = 0, lower_m = 0;
    glm::vec3 default_pole{0};  // mid-joint direction with nothing else to go on (root frame)
  };

 private:
  friend class SolverContext;
  friend struct SolveJob;
  friend class LimbLengthEstimator;
  friend void hang_untracked_feet(const SolverModel&, SolverContext&, const rig::Pose&, std::array<bool, 2>);
  // New link lengths of a two-bone chain (functional calibration): both offsets keep their
  // direction. No allocation. False when a length is not positive and finite.
  bool set_chain_lengths(int chain, float upper_m, float lower_m);
  rig::Skeleton skeleton_;
  std::vector<SensorMount> mounts_;
  SolverOptions options_;
  std::vector<int> slot_of_sensor_;                       // sensor id → mount index or -1
  std::vector<int> mount_joint_;                          // per mount
  std::vector<rig::RigidTransform> sensor_from_segment_;  // per mount
  std::vector<int> trunk_dofs_;                           // spine, neck, head
  std::vector<int> trunk_joints_;
  std::vector<int> leg_dofs_;                 // hips and knees (root placed from the feet)
  std::array<std::vector<int>, 2> arm_dofs_;  // clavicle, shoulder, elbow bend
  std::array<Chain, 4> chains_{};             // l arm, r arm, l leg, r leg
  std::vector<int8_t> chain_of_joint_;        // chain index for upper/mid/end joints, else -1
  std::vector<float> prior_rad_;              // relaxed values
  int head_ = -1;
  glm::vec3 head_from_root_rest_{0.0f};           // head joint relative to the root, relaxed posture
  std::array<float, 2> ankle_below_root_rest_{};  // root height above each ankle, zero posture
  std::array<glm::vec3, 2> ball_in_ankle_{};      // toes joint (ball of the foot) in the ankle frame
  std::array<int, 2> toes_{-1, -1};
  std::array<float, 2> toe_tip_below_root_rest_{};  // root height above each toe tip, zero posture
  std::array<float, 2> ball_below_root_rest_{};     // … above each ball of the foot
};

class SolverContext {
  friend void hang_untracked_feet(const SolverModel&, SolverContext&, const rig::Pose&, std::array<bool, 2>);

 public:
  explicit SolverContext(const SolverModel& model);           // allocates; call at setup
  void reset() { have_previous_ = false, locomotion_ = {}; }  // forget the warm start and steps
  const LocomotionState& locomotion() const { return locomotion_; }

 private:
  friend struct SolveJob;
  LeastSquaresIkContext ls_;
  std::vector<IkTarget> targets_;
  std::vector<int> ls_dofs_;
  std::vector<float> prior_;
  std::vector<rig::RigidTransform> segment_target_;  // per joint
  std::vector<uint8_t> has_target_;                  // per joint
  std::array<bool, 4> guessed_end_{};                // per chain: its end target is a guess
  std::vector<rig::RigidTransform> world_;
  std::array<glm::vec3, 4> last_bend_world_{};
  bool have_previous_ = false;
  LocomotionState locomotion_;
  double last_time_s_ = -1;  // the newest sample's time the frame before (−1: none yet)
  // This frame's clock (GatherTargets): the newest valid sample's time (−1: none) and the time
  // since last_time_s_ (1/120 s when either is unknown).
  double sample_time_s_ = -1;
  float sample_step_s_ = 1.0f / 120;
};

struct SolveJob {
  // [in]
  const SolverModel* model = nullptr;
  std::span<const devices::SensorSample> samples;  // newest sample per sensor; samples without
                                                   // kSampleValid, unknown ids or non-finite
                                                   // values are ignored
  SolverContext* context = nullptr;
  // [in, out] warm start (the previous frame's solution, or zero_pose()) in, solution out
  rig::Pose* pose = nullptr;
  // [out]
  int sensors_used = 0;
  int ls_iterations = 0;

  bool Validate() const;
  bool Run();

 private:
  // The stages of Run() (body_solver.cpp, locomotion.cpp).
  void GatherTargets();
  void AddRootTargets();
  IkTarget StandingRootTarget(const glm::quat& heading);
  void FollowWalkingHead(const glm::quat& heading, const glm::vec3& head_up, glm::vec3& goal, float& weight);
  glm::quat TurnTowardsTheHands(const glm::quat& head_heading);
  void AddArmTargets();
  void SolveTrunk(bool root_known);
  void place_untracked_feet();
  void SolveLimbsAndRest(bool trunk_observed);
  bool SolveLimb(int chain);
  void LiftSteppedFootOffFloor(int chain);            // locomotion.cpp
  void KeepBallAboveFloor(int chain, float floor_y);  // locomotion.cpp
  void PlaceJoint(int joint);
  void OrientFromTarget(int joint);
};

}  // namespace mimic::solver
