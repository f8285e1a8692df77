// Built-in procedural motions: "idle" (relaxed standing), "walk" and "run" (gait cycles around
// a circle). All loop seamlessly: every periodic term has a whole number of periods in one
// loop. The idle's pelvis height is not authored: a table, computed once, lifts the root so the
// lowest point of either sole touches the floor (y = 0) at every instant; the gaits place their
// feet and take the pelvis height from the legs' reach (GaitMotion).
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "mimic/rig/joint_angles.h"
#include "mimic/rig/motion.h"

namespace mimic::rig {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;
constexpr double kSole_m = 0.018;     // sole below the toe joints (as standing_root_height_m)
constexpr double kHeelBack_m = 0.05;  // heel behind the ankle

double rad(double deg) { return deg * kPi / 180.0; }

// The DOFs the motions drive, resolved to skeleton indices once (sample() must not search
// or allocate). Absent DOFs (another skeleton) resolve to -1 and are skipped.
enum NamedDof : int {
  kLHipAbduction,
  kRHipAbduction,
  kLAnkleInversion,
  kRAnkleInversion,
  kLKneeFlexion,
  kRKneeFlexion,
  kLHipFlexion,
  kRHipFlexion,
  kLAnkleFlexion,
  kRAnkleFlexion,
  kLHipRotation,
  kRHipRotation,
  kSpineLowerFlexion,
  kSpineLowerTwist,
  kSpineLowerLateralBend,
  kSpineMidTwist,
  kSpineMidLateralBend,
  kSpineUpperFlexion,
  kSpineUpperLateralBend,
  kLClavicleElevation,
  kRClavicleElevation,
  kNeckTwist,
  kNeckFlexion,
  kHeadTwist,
  kHeadFlexion,
  kHeadLateralBend,
  kLWristFlexion,
  kRWristFlexion,
  kLElbowFlexion,
  kRElbowFlexion,
  kNamedDofCount
};
constexpr const char* kNamedDofs[kNamedDofCount] = {
    "l_hip_abduction",
    "r_hip_abduction",
    "l_ankle_inversion",
    "r_ankle_inversion",
    "l_knee_flexion",
    "r_knee_flexion",
    "l_hip_flexion",
    "r_hip_flexion",
    "l_ankle_flexion",
    "r_ankle_flexion",
    "l_hip_rotation",
    "r_hip_rotation",
    "spine_lower_flexion",
    "spine_lower_twist",
    "spine_lower_lateral_bend",
    "spine_mid_twist",
    "spine_mid_lateral_bend",
    "spine_upper_flexion",
    "spine_upper_lateral_bend",
    "l_clavicle_elevation",
    "r_clavicle_elevation",
    "neck_twist",
    "neck_flexion",
    "head_twist",
    "head_flexion",
    "head_lateral_bend",
    "l_wrist_flexion",
    "r_wrist_flexion",
    "l_elbow_flexion",
    "r_elbow_flexion",
};

class ProceduralMotion : public Motion {
 public:
  ProceduralMotion(const Skeleton& skeleton, std::string name, double duration_s)
      : skeleton_(skeleton), name_(std::move(name)), duration_s_(duration_s) {
    for (int k = 0; k < kNamedDofCount; ++k) dof_index_[k] = skeleton_.find_dof(kNamedDofs[k]);
    for (int k = 0; k < 2; ++k) {
      shoulder_[k] = skeleton_.find_joint(k == 0 ? "l_shoulder" : "r_shoulder");
      ankle_[k] = skeleton_.find_joint(k == 0 ? "l_ankle" : "r_ankle");
      toes_[k] = skeleton_.find_joint(k == 0 ? "l_toes" : "r_toes");
    }
  }

  const Skeleton& skeleton() const override { return skeleton_; }
  double duration_s() const override { return duration_s_; }
  bool loops() const override { return true; }
  std::string name() const override { return name_; }

  void sample(double t_s, Pose& out) const override {
    double t = std::isfinite(t_s) ? std::fmod(t_s, duration_s_) : 0.0;
    if (t < 0) t += duration_s_;
    out.dof_rad.resize(skeleton_.dof_count());  // no-op once sized
    shape(t, out);
    if (!heights_.empty()) out.root_position_m.y = static_cast<float>(root_height(t));
    clamp_to_limits(skeleton_, out);  // authored for the default body; others may reach a limit
  }

 protected:
  // Sets every DOF and the root at time t in [0, duration); if the motion built a height
  // table, the root height comes from it.
  virtual void shape(double t, Pose& out) const = 0;

  void set(Pose& p, NamedDof d, double value_rad) const {
    if (dof_index_[d] >= 0) p.dof_rad[dof_index_[d]] = static_cast<float>(value_rad);
  }

  // Derived constructors call this once their parameters are set.
  void build_height_table(int samples) {
    heights_.resize(samples);
    std::vector<RigidTransform> world(skeleton_.joint_count());
    Pose p = skeleton_.zero_pose();
    for (int i = 0; i < samples; ++i) {
      shape(duration_s_ * i / samples, p);
      p.root_position_m.y = 0;
      forward_kinematics(skeleton_, p, world);
      heights_[i] = -lowest_sole_point(world);
    }
  }

  // Lowest point of either sole: heel under the ankle, ball under the toe joint, toe tip.
  double lowest_sole_point(std::span<const RigidTransform> world) const {
    double lowest = 1e9;
    for (int k = 0; k < 2; ++k) {
      const int ankle = ankle_[k], toes = toes_[k];
      if (ankle < 0) continue;
      if (toes < 0) {
        lowest = std::min(lowest, double(world[ankle].translation.y) - kSole_m);
        continue;
      }
      const glm::vec3 ball_in_ankle = skeleton_.offset_m(toes);
      const glm::vec3 heel(0.0f, ball_in_ankle.y - float(kSole_m), -float(kHeelBack_m));
      const glm::vec3 sole(0.0f, -float(kSole_m), 0.0f);
      lowest = std::min(lowest, double(world[ankle].apply(heel).y));
      lowest = std::min(lowest, double(world[toes].apply(sole).y));
      lowest = std::min(lowest, double(world[toes].apply(skeleton_.tip_m(toes) + sole).y));
    }
    return lowest > 1e8 ? 0.0 : lowest;
  }

  // Shoulder DOFs for an arm hanging by `abduction` (from the T-pose, negative = down) and
  // swung forward by `swing` about the body's left-right axis; left-side convention (the
  // right side takes equal values for the mirror-image posture).
  // side: 0 left, 1 right.
  void arm(Pose& p, int side, double swing_rad, double abduction_rad, double elbow_rad) const {
    const int shoulder = shoulder_[0], target = shoulder_[side];
    if (shoulder < 0 || target < 0 || skeleton_.dof_end(shoulder) - skeleton_.dof_begin(shoulder) != 3) return;
    std::array<glm::dvec3, 3> axes;
    for (int k = 0; k < 3; ++k) axes[k] = glm::dvec3(skeleton_.dof(skeleton_.dof_begin(shoulder) + k).axis);
    const glm::dquat q =
        glm::angleAxis(-swing_rad, glm::dvec3(1, 0, 0)) * glm::angleAxis(abduction_rad, glm::dvec3(0, 0, 1));
    // A fixed reference keeps the answer a pure function of time, on the hanging-arm branch.
    const double reference[3] = {0.0, abduction_rad, 0.0};
    double out[3];
    dofs_from_rotation(axes, q, reference, out);
    for (int k = 0; k < 3; ++k) p.dof_rad[skeleton_.dof_begin(target) + k] = static_cast<float>(out[k]);
    set(p, side == 0 ? kLElbowFlexion : kRElbowFlexion, elbow_rad);
  }

  double root_height(double t) const {
    const int n = static_cast<int>(heights_.size());
    const double x = t / duration_s_ * n;
    const int i = static_cast<int>(std::floor(x));
    const double a = x - i;
    return heights_[((i % n) + n) % n] * (1 - a) + heights_[((i + 1) % n + n) % n] * a;
  }

  Skeleton skeleton_;
  std::string name_;
  double duration_s_;
  std::vector<double> heights_;
  std::array<int, kNamedDofCount> dof_index_{};
  std::array<int, 2> shoulder_{-1, -1}, ankle_{-1, -1}, toes_{-1, -1};
};

// Relaxed standing: arms down with a slight elbow bend, breathing (4 s), a slow weight shift
// from foot to foot with the feet planted (12 s), and the head glancing about (6 s, 4 s). As
// still as a person asked to stand still: a calibration's stand-still (3 cm and 6° per sensor
// over its 2 s capture) accepts any stretch of it.
class IdleMotion final : public ProceduralMotion {
 public:
  explicit IdleMotion(const Skeleton& s) : ProceduralMotion(s, "idle", 12.0) {
    const int hip = s.find_joint("l_hip"), ankle = s.find_joint("l_ankle");
    if (hip >= 0 && ankle >= 0) {
      std::vector<RigidTransform> w(s.joint_count());
      forward_kinematics(s, s.zero_pose(), w);
      leg_m_ = std::max(0.1f, glm::length(w[hip].translation - w[ankle].translation));
    }
    build_height_table(1200);
  }

 private:
  void shape(double t, Pose& p) const override {
    const double w12 = kTwoPi * t / 12.0, w6 = kTwoPi * t / 6.0, w4 = kTwoPi * t / 4.0, w3 = kTwoPi * t / 3.0;
    for (auto& v : p.dof_rad) v = 0;
    const double breath = 0.5 - 0.5 * std::cos(w4);  // 0 exhaled .. 1 inhaled
    // Weight shift: the pelvis moves sideways over one foot, then the other; legs lean to keep
    // the feet where they are, ankles keep the soles flat.
    const double shift_m = 0.012 * std::sin(w12);
    const double lean = std::asin(std::clamp(shift_m / leg_m_, -0.5, 0.5));
    const double yaw = rad(1.0) * std::sin(w12 + 0.7);
    p.root_orientation = glm::quat(glm::angleAxis(yaw, glm::dvec3(0, 1, 0)));
    p.root_position_m = glm::vec3(glm::dquat(p.root_orientation) * glm::dvec3(shift_m, 0, 0));
    set(p, kLHipAbduction, -lean);
    set(p, kRHipAbduction, lean);
    set(p, kLAnkleInversion, -lean);
    set(p, kRAnkleInversion, lean);
    // Soft knees: hips and ankles share the bend so the shin stays over the foot.
    const double knee = rad(4.0);
    for (NamedDof d : {kLKneeFlexion, kRKneeFlexion}) set(p, d, knee);
    for (NamedDof d : {kLHipFlexion, kRHipFlexion, kLAnkleFlexion, kRAnkleFlexion}) set(p, d, 0.5 * knee);
    // The hips undo the pelvis yaw so the feet keep pointing where they stand (the right
    // axis mirrors the left, so a global yaw needs opposite values).
    set(p, kLHipRotation, yaw);
    set(p, kRHipRotation, -yaw);
    // Torso: breathing lifts the chest and clavicles; the spine undoes the pelvis yaw.
    set(p, kSpineLowerFlexion, rad(2.0));
    set(p, kSpineMidTwist, -0.6 * yaw);
    set(p, kSpineUpperFlexion, rad(-1.5) * breath);
    set(p, kSpineUpperLateralBend, rad(1.0) * std::sin(w12));
    set(p, kLClavicleElevation, rad(1.5) * breath);
    set(p, kRClavicleElevation, rad(1.5) * breath);
    // The head glances about slowly, nodding a little.
    set(p, kNeckTwist, rad(2.0) * std::sin(w6) - 0.4 * yaw);
    set(p, kHeadTwist, rad(1.0) * std::sin(w6 + 0.3));
    set(p, kNeckFlexion, rad(5.0) + rad(1.0) * std::sin(w4 + 1.0));
    set(p, kHeadFlexion, rad(-3.0) + rad(0.5) * std::sin(w3));
    set(p, kHeadLateralBend, rad(2.0) * std::sin(w12 + 2.0));
    // Arms hang about 75° below the T-pose with a slight elbow bend, drifting with the sway.
    arm(p, 0, rad(4.0) + rad(1.0) * std::sin(w12), rad(-75.0) + rad(1.0) * breath, rad(14.0) + rad(1.0) * std::sin(w6));
    arm(p, 1, rad(4.0) - rad(1.0) * std::sin(w12), rad(-75.0) + rad(1.0) * breath,
        rad(14.0) - rad(1.0) * std::sin(w6 + 0.5));
    set(p, kLWristFlexion, rad(5.0));
    set(p, kRWristFlexion, rad(5.0));
  }

  float leg_m_ = 0.8f;
};

// A gait around a circle about the origin (the centre on the mover's right), a whole number of
// gait cycles per lap so the loop is seamless: "walk" (1.2 m circle, 1.1 s cycles) and "run"
// (5 m circle, 0.72 s cycles, each foot on the floor 36 % of a cycle: both feet are in the air
// between the stances).
//
// The feet are placed, not the angles: each footstep is planted on the floor for the stance
// phase while the foot rolls over the heel, lies flat, then rises onto the ball with the toes
// staying flat; in swing the ankle travels to the next footprint on a clearance arc (a run's heel
// kicks up behind). Each leg is then solved exactly (hip 3 DOFs + knee flexion as a two-bone
// chain with the knee forward, ankle for the foot's orientation, toes to keep the toes flat), so
// stance feet neither slide nor sink. Walking, the pelvis is as high as the legs allow (a smooth
// minimum of the standing height and each leg's reach), which gives the natural bob; running, it
// is lowest at each mid-stance (the knee gives) and highest in flight.
struct Gait {
  const char* name;
  double radius_m, period_s;
  double stance;                        // fraction of the cycle a foot is down
  double stride_legs;                   // stride about this many × (thigh + shin)
  double heel_strike_deg, toe_off_deg;  // foot pitch at heel strike (toes up) and toe-off (heel up)
  double step_width_m;                  // footprint centre from the path
  double strike_lead;                   // a footprint this much of a stride ahead of the pelvis at strike
  bool run;
};
constexpr Gait kWalk{"walk", 1.2, 1.1, 0.6, 1.6, 12.0, -38.0, 0.085, 0.25, false};
constexpr Gait kRun{"run", 5.0, 0.72, 0.36, 2.7, 6.0, -30.0, 0.05, 0.18, true};

class GaitMotion final : public ProceduralMotion {
 public:
  GaitMotion(const Skeleton& s, const Gait& g) : ProceduralMotion(s, g.name, 1.0), g_(g) {
    for (int k = 0; k < 2; ++k) {
      const std::string side = k == 0 ? "l_" : "r_";
      Leg& leg = legs_[k];
      leg.hip = s.find_joint(side + "hip");
      leg.knee = s.find_joint(side + "knee");
      leg.ankle = s.find_joint(side + "ankle");
      leg.toes = s.find_joint(side + "toes");
      leg.side = k == 0 ? 1.0 : -1.0;
      leg.phase_offset = k == 0 ? 0.0 : 0.5;
    }
    const Leg& l = legs_[0];
    const double thigh = glm::length(s.offset_m(l.knee)), shin = glm::length(s.offset_m(l.ankle));
    leg_reach_m_ = 0.995 * (thigh + shin);
    const glm::dvec3 ball(s.offset_m(l.toes));
    ankle_height_m_ = -(ball.y - kSole_m);  // ankle above the floor with the foot flat
    ball_z_m_ = ball.z;
    standing_root_m_ = standing_root_height_m(s);
    hip_offset_ = glm::dvec3(s.offset_m(l.hip));
    // Walking, a stride of about 1.6 × (thigh + shin): 1.27 m on the default body, 6 cycles a lap.
    const double circumference = kTwoPi * g_.radius_m;
    // Rounding up: a longer body takes slightly short steps rather than overlong ones.
    cycles_ = std::max(3, static_cast<int>(std::ceil(circumference / (g_.stride_legs * (thigh + shin)))));
    duration_s_ = cycles_ * g_.period_s;
    stride_m_ = circumference / cycles_;
  }

  static bool supports(const Skeleton& s) {
    for (const char* j : {"l_hip", "l_knee", "l_ankle", "l_toes", "r_hip", "r_knee", "r_ankle", "r_toes"})
      if (s.find_joint(j) < 0) return false;
    for (const char* j : {"l_hip", "r_hip", "l_ankle", "r_ankle"}) {
      const int k = s.find_joint(j);
      if (s.dof_end(k) - s.dof_begin(k) != 3) return false;
    }
    return s.parent(s.find_joint("l_hip")) == 0 && s.parent(s.find_joint("r_hip")) == 0;
  }

 private:
  struct Leg {
    int hip = -1, knee = -1, ankle = -1, toes = -1;
    double side = 1;  // +1 left (outside of the circle), −1 right
    double phase_offset = 0;
  };
  struct FootState {
    glm::dvec3 ankle;     // world
    glm::dquat rotation;  // foot (ankle frame) world rotation
    double toes_rad;      // toe flexion keeping the toes flat
  };

  static double smooth(double u) {
    u = std::clamp(u, 0.0, 1.0);
    return u * u * (3 - 2 * u);
  }
  double omega() const { return kTwoPi / duration_s_; }  // path angle rate

  // Foot pitch during stance, u in [0, 1): heel rocker, flat, heel rise.
  double stance_pitch(double u) const {
    if (u < 0.17) return rad(g_.heel_strike_deg) * (1 - smooth(u / 0.17));
    if (u < 0.55) return 0.0;
    const double w = (u - 0.55) / 0.45;
    return rad(g_.toe_off_deg) * w * w;
  }

  // Stance foot: planted at path angle psi_k, pitched by p about the heel (p > 0) or the
  // ball (p < 0).
  FootState planted(const Leg& leg, double psi_k, double pitch) const {
    const glm::dquat yaw = glm::angleAxis(-psi_k, glm::dvec3(0, 1, 0));
    const glm::dvec3 print =
        (g_.radius_m + leg.side * g_.step_width_m) * glm::dvec3(std::cos(psi_k), 0, std::sin(psi_k));
    const glm::dvec3 flat_ankle(0, ankle_height_m_, 0);
    // Heel rocker about the heel's floor contact; heel rise about the toe joint itself (the
    // toes stay flat, so the ball of the foot does not move).
    const glm::dvec3 pivot = pitch >= 0 ? glm::dvec3(0, 0, -kHeelBack_m) : glm::dvec3(0, kSole_m, ball_z_m_);
    const glm::dquat pitch_q = glm::angleAxis(-pitch, glm::dvec3(1, 0, 0));
    FootState f;
    f.ankle = print + yaw * (pivot + pitch_q * (flat_ankle - pivot));
    f.rotation = yaw * pitch_q;
    f.toes_rad = std::min(0.0, pitch);  // on the ball the toes stay flat
    return f;
  }

  // Path angle at which footstep k of a leg is planted: a little ahead of the pelvis at heel
  // strike, so the leg sweeps symmetrically under the body.
  double footprint_psi(const Leg& leg, double step) const {
    const double t_strike = (step + leg.phase_offset) * g_.period_s;
    return omega() * t_strike + g_.strike_lead * stride_m_ / g_.radius_m;
  }

  FootState foot(const Leg& leg, double t) const {
    const double cycle = t / g_.period_s - leg.phase_offset;
    const double step = std::floor(cycle);
    const double ph = cycle - step;
    if (ph < g_.stance) return planted(leg, footprint_psi(leg, step), stance_pitch(ph / g_.stance));
    // Swing: from toe-off to the next heel strike.
    const double u = (ph - g_.stance) / (1 - g_.stance);
    const FootState a = planted(leg, footprint_psi(leg, step), stance_pitch(1.0));
    const FootState b = planted(leg, footprint_psi(leg, step + 1), stance_pitch(0.0));
    const double su = smooth(u);
    FootState f;
    // Along the foot's own circle, not the chord: a stride spans a sixth of the lap, and the
    // outer foot's chord cut 15 cm inwards, through the other leg.
    const double ra = std::hypot(a.ankle.x, a.ankle.z), rb = std::hypot(b.ankle.x, b.ankle.z);
    const double pa = std::atan2(a.ankle.z, a.ankle.x);
    const double turn = std::remainder(std::atan2(b.ankle.z, b.ankle.x) - pa, kTwoPi);
    const double r = ra + su * (rb - ra), psi = pa + su * turn;
    f.ankle = glm::dvec3(r * std::cos(psi), a.ankle.y + su * (b.ankle.y - a.ankle.y), r * std::sin(psi));
    if (g_.run)
      f.ankle.y += 0.30 * std::sin(kPi * u) * (1 - 0.3 * u);  // up behind, lowering through the swing
    else
      f.ankle.y += 0.045 * std::sin(kPi * u) + 0.03 * std::sin(kPi * std::min(1.0, u / 0.5)) * (1 - u);
    // The foot turns from its toe-off pitch to the heel-strike pitch: toes down early in swing
    // with the shin, as in real gait, rather than held level (which would overbend the ankle).
    f.rotation = glm::slerp(a.rotation, b.rotation, su);
    f.toes_rad = a.toes_rad * (1 - smooth(u / 0.4));
    return f;
  }

  // Highest root height at which a leg still reaches its ankle target.
  double reach_bound(const glm::dquat& root_rot, const glm::dvec3& root_xz, const Leg& leg,
                     const glm::dvec3& ankle) const {
    const glm::dvec3 hip_offset(leg.side * hip_offset_.x, hip_offset_.y, hip_offset_.z);
    const glm::dvec3 hip0 = root_xz + root_rot * hip_offset;  // root at height 0
    const glm::dvec3 d = ankle - hip0;
    const double horizontal2 = d.x * d.x + d.z * d.z;
    return ankle.y - hip0.y + std::sqrt(std::max(0.0, leg_reach_m_ * leg_reach_m_ - horizontal2));
  }

  void solve_leg(Pose& p, const Leg& leg, const glm::dquat& root_rot, const glm::dvec3& root_pos, const FootState& f,
                 const glm::dvec3& forward) const {
    const Skeleton& s = skeleton_;
    const glm::dvec3 off_knee(s.offset_m(leg.knee)), off_ankle(s.offset_m(leg.ankle));
    const double l1 = glm::length(off_knee), l2 = glm::length(off_ankle);
    const glm::dvec3 hip = root_pos + root_rot * glm::dvec3(s.offset_m(leg.hip));
    glm::dvec3 d = f.ankle - hip;
    double dist = glm::length(d);
    const glm::dvec3 dh = d / dist;
    dist = std::clamp(dist, std::abs(l1 - l2) + 1e-6, l1 + l2 - 1e-9);
    const double ca = std::clamp((l1 * l1 + dist * dist - l2 * l2) / (2 * l1 * dist), -1.0, 1.0);
    const glm::dvec3 n = glm::normalize(forward - glm::dot(forward, dh) * dh);  // knee forward
    const glm::dvec3 u = ca * dh + std::sqrt(1 - ca * ca) * n;
    const glm::dvec3 knee = hip + l1 * u;
    const glm::dvec3 v = glm::normalize(hip + dist * dh - knee);
    const glm::dvec3 hinge_w = glm::normalize(glm::cross(n, dh));
    const glm::dvec3 a = off_knee / l1, h(s.dof(s.dof_begin(leg.knee)).axis);
    const glm::dmat3 world(u, hinge_w, glm::cross(u, hinge_w)), local(a, h, glm::cross(a, h));
    const glm::dquat thigh = glm::quat_cast(world * glm::transpose(local));
    const double zero3[3] = {0, 0, 0};
    solve_dofs(p, leg.hip, glm::inverse(root_rot) * thigh, zero3);
    const glm::dvec3 b_w = thigh * (off_ankle / l2);
    const double flex = std::atan2(glm::dot(hinge_w, glm::cross(b_w, v)), glm::dot(b_w, v));
    p.dof_rad[s.dof_begin(leg.knee)] = static_cast<float>(flex);
    const glm::dquat shin = thigh * glm::angleAxis(flex, h);
    solve_dofs(p, leg.ankle, glm::inverse(shin) * f.rotation, zero3);
    if (s.dof_end(leg.toes) > s.dof_begin(leg.toes)) p.dof_rad[s.dof_begin(leg.toes)] = static_cast<float>(f.toes_rad);
  }

  void solve_dofs(Pose& p, int joint, const glm::dquat& local, const double* reference) const {
    const Skeleton& s = skeleton_;
    const int begin = s.dof_begin(joint);
    std::array<glm::dvec3, 3> axes;
    for (int k = 0; k < 3; ++k) axes[k] = glm::dvec3(s.dof(begin + k).axis);
    double out[3];
    dofs_from_rotation(axes, local, std::span<const double>(reference, 3), out);
    for (int k = 0; k < 3; ++k) p.dof_rad[begin + k] = static_cast<float>(out[k]);
  }

  void shape(double t, Pose& p) const override {
    for (auto& v : p.dof_rad) v = 0;
    const double ph = std::fmod(t / g_.period_s, 1.0);  // left heel strike at 0
    const double c = std::cos(kTwoPi * ph), sn = std::sin(kTwoPi * ph);
    // Pelvis: turns forward with the leading leg, drops on the swing side, sways over the
    // stance foot, tilts forward a little.
    const double psi = omega() * t;
    const glm::dquat heading = glm::angleAxis(-psi, glm::dvec3(0, 1, 0));
    const double pelvis_yaw = rad(-4.0) * c;
    const double obliquity = rad(3.0) * sn;
    const glm::dquat root_rot =
        glm::normalize(heading * glm::angleAxis(pelvis_yaw, glm::dvec3(0, 1, 0)) *
                       glm::angleAxis(obliquity, glm::dvec3(0, 0, 1)) * glm::angleAxis(rad(3.0), glm::dvec3(1, 0, 0)));
    const glm::dvec3 root_xz =
        g_.radius_m * glm::dvec3(std::cos(psi), 0, std::sin(psi)) + heading * glm::dvec3(0.02 * sn, 0, 0);
    const FootState fl = foot(legs_[0], t), fr = foot(legs_[1], t);
    // As high as standing allows and both legs reach (smooth minimum, never above either);
    // running, lowest at each mid-stance (the knee gives), highest in flight.
    auto smin = [](double x, double y, double k) { return -k * std::log(std::exp(-x / k) + std::exp(-y / k)); };
    double height = standing_root_m_ - 0.005;
    if (g_.run) height -= 0.075 + 0.035 * std::cos(kTwoPi * 2 * (ph - 0.5 * g_.stance));
    height = smin(height, reach_bound(root_rot, root_xz, legs_[0], fl.ankle), 0.01);
    height = smin(height, reach_bound(root_rot, root_xz, legs_[1], fr.ankle), 0.01);
    const glm::dvec3 root_pos(root_xz.x, height, root_xz.z);
    p.root_orientation = glm::quat(root_rot);
    p.root_position_m = glm::vec3(root_pos);
    const glm::dvec3 forward = heading * glm::dvec3(0, 0, 1);
    solve_leg(p, legs_[0], root_rot, root_pos, fl, forward);
    solve_leg(p, legs_[1], root_rot, root_pos, fr, forward);
    // Torso: the spine undoes the pelvic tilt, rotation and obliquity so the chest stays calm
    // and the shoulders counter-rotate a little; a runner leans into the run.
    set(p, kSpineLowerFlexion, rad(g_.run ? 5.0 : -1.0));
    set(p, kSpineLowerTwist, -0.6 * pelvis_yaw);
    set(p, kSpineMidTwist, -0.8 * pelvis_yaw);
    set(p, kSpineLowerLateralBend, 0.6 * obliquity);  // the bend turns about -Z, the obliquity about +Z
    set(p, kSpineMidLateralBend, 0.4 * obliquity);
    set(p, kNeckFlexion, rad(3.0));
    set(p, kHeadFlexion, rad(-2.0));
    set(p, kNeckTwist, rad(-6.0));  // looking a little into the curve
    // Arms swing against the legs: the left arm forward while the left leg is back (running,
    // further, elbows bent).
    const double amplitude = rad(g_.run ? 26.0 : 14.0), elbow = rad(g_.run ? 85.0 : 18.0);
    const double swing_l = rad(3.0) - amplitude * std::cos(kTwoPi * (ph - 0.93));
    const double swing_r = rad(3.0) - amplitude * std::cos(kTwoPi * (ph + 0.5 - 0.93));
    // (A runner's arms held a little off the body: hanging nearer the shoulder's gimbal, a swing
    // this wide turned its flexion and twist 7° a sample.)
    const double abduction = rad(g_.run ? -68.0 : -78.0);
    arm(p, 0, swing_l, abduction, elbow + 0.6 * std::max(0.0, swing_l));
    arm(p, 1, swing_r, abduction, elbow + 0.6 * std::max(0.0, swing_r));
  }

  Gait g_;
  std::array<Leg, 2> legs_;
  double leg_reach_m_ = 0.79, ankle_height_m_ = 0.073, ball_z_m_ = 0.135, standing_root_m_ = 0.89;
  double stride_m_ = 1.25;
  int cycles_ = 6;
  glm::dvec3 hip_offset_{0.11, -0.023, 0};
};

}  // namespace

Result<std::unique_ptr<Motion>> make_builtin_motion(std::string_view name, const Skeleton& skeleton) {
  if (name == "idle") return std::unique_ptr<Motion>(std::make_unique<IdleMotion>(skeleton));
  if (name == "walk" || name == "run") {
    if (!GaitMotion::supports(skeleton))
      return fail(Errc::invalid_argument,
                  std::string(name) + " needs Mimic's leg joints (l_/r_ hip, knee, ankle, toes; hips on the root)");
    return std::unique_ptr<Motion>(std::make_unique<GaitMotion>(skeleton, name == "walk" ? kWalk : kRun));
  }
  return fail(Errc::not_found, "unknown motion '" + std::string(name) + "' (built in: idle, walk, run)");
}

std::vector<std::string> builtin_motion_names() { return {"idle", "walk", "run"}; }

}  // namespace mimic::rig
