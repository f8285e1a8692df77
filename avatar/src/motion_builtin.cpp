// Built-in procedural motions: "idle" (relaxed standing) and "walk" (a gait cycle around a
// circle). Both loop seamlessly: every periodic term has a whole number of periods in one
// loop. The pelvis height is not authored: a table, computed once per motion, lifts the root
// so the lowest point of either sole touches the floor (y = 0) at every instant, which also
// gives the walk its natural vertical bob.
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "mimic/avatar/joint_angles.h"
#include "mimic/avatar/motion.h"

namespace mimic::avatar {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;
constexpr double kSole_m = 0.018;     // sole below the toe joints (as standing_root_height_m)
constexpr double kHeelBack_m = 0.05;  // heel behind the ankle

double rad(double deg) { return deg * kPi / 180.0; }

// Periodic bump on a unit phase circle: 1 at `centre`, Gaussian of width `sigma`.
double bump(double phase, double centre, double sigma) {
  double d = phase - centre;
  d -= std::round(d);
  return std::exp(-0.5 * d * d / (sigma * sigma));
}

class ProceduralMotion : public Motion {
 public:
  ProceduralMotion(const Skeleton& skeleton, std::string name, double duration_s)
      : skeleton_(skeleton), name_(std::move(name)), duration_s_(duration_s) {}

  const Skeleton& skeleton() const override { return skeleton_; }
  double duration_s() const override { return duration_s_; }
  bool loops() const override { return true; }
  std::string name() const override { return name_; }

  void sample(double t_s, Pose& out) const override {
    double t = std::isfinite(t_s) ? std::fmod(t_s, duration_s_) : 0.0;
    if (t < 0) t += duration_s_;
    out.dof_rad.resize(skeleton_.dof_count());  // no-op once sized
    shape(t, out);
    out.root_position_m.y = static_cast<float>(root_height(t));
  }

 protected:
  // Sets every DOF, the root orientation and the root's horizontal position at time t in
  // [0, duration); root height is added from the table.
  virtual void shape(double t, Pose& out) const = 0;

  int dof(const char* name) const { return skeleton_.find_dof(name); }
  static void set(Pose& p, int index, double value_rad) {
    if (index >= 0) p.dof_rad[index] = static_cast<float>(value_rad);
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
    for (const char* side : {"l_", "r_"}) {
      const int ankle = skeleton_.find_joint(std::string(side) + "ankle");
      const int toes = skeleton_.find_joint(std::string(side) + "toes");
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
  void arm(Pose& p, const char* side, double swing_rad, double abduction_rad, double elbow_rad) const {
    const std::string s(side);
    const int shoulder = skeleton_.find_joint("l_shoulder");
    const int target = skeleton_.find_joint(s + "shoulder");
    if (shoulder < 0 || target < 0 || skeleton_.dof_end(shoulder) - skeleton_.dof_begin(shoulder) != 3) return;
    std::array<glm::dvec3, 3> axes;
    for (int k = 0; k < 3; ++k) axes[k] = glm::dvec3(skeleton_.dof(skeleton_.dof_begin(shoulder) + k).axis);
    const glm::dquat q = glm::angleAxis(-swing_rad, glm::dvec3(1, 0, 0)) * glm::angleAxis(abduction_rad, glm::dvec3(0, 0, 1));
    // A fixed reference keeps the answer a pure function of time, on the hanging-arm branch.
    const double reference[3] = {0.0, abduction_rad, 0.0};
    double out[3];
    dofs_from_rotation(axes, q, reference, out);
    for (int k = 0; k < 3; ++k) p.dof_rad[skeleton_.dof_begin(target) + k] = static_cast<float>(out[k]);
    set(p, dof((s + "elbow_flexion").c_str()), elbow_rad);
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
};

// Relaxed standing: arms down with a slight elbow bend, breathing (4 s), a slow weight shift
// from foot to foot with the feet planted (12 s), and the head looking around (6 s, 4 s).
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
    const double shift_m = 0.025 * std::sin(w12);
    const double lean = std::asin(std::clamp(shift_m / leg_m_, -0.5, 0.5));
    const double yaw = rad(2.0) * std::sin(w12 + 0.7);
    p.root_orientation = glm::quat(glm::angleAxis(yaw, glm::dvec3(0, 1, 0)));
    p.root_position_m = glm::vec3(glm::dquat(p.root_orientation) * glm::dvec3(shift_m, 0, 0));
    set(p, dof("l_hip_abduction"), -lean);
    set(p, dof("r_hip_abduction"), lean);
    set(p, dof("l_ankle_inversion"), -lean);
    set(p, dof("r_ankle_inversion"), lean);
    // Soft knees: hips and ankles share the bend so the shin stays over the foot.
    const double knee = rad(4.0);
    for (const char* s : {"l_", "r_"}) {
      const std::string side(s);
      set(p, dof((side + "knee_flexion").c_str()), knee);
      set(p, dof((side + "hip_flexion").c_str()), 0.5 * knee);
      set(p, dof((side + "ankle_flexion").c_str()), 0.5 * knee);
      set(p, dof((side + "hip_rotation").c_str()), -yaw * 0.5);
    }
    // Torso: breathing lifts the chest and clavicles; the spine undoes the pelvis yaw.
    set(p, dof("spine_lower_flexion"), rad(2.0));
    set(p, dof("spine_mid_twist"), -0.6 * yaw);
    set(p, dof("spine_upper_flexion"), rad(-1.5) * breath);
    set(p, dof("spine_upper_lateral_bend"), rad(1.0) * std::sin(w12));
    set(p, dof("l_clavicle_elevation"), rad(1.5) * breath);
    set(p, dof("r_clavicle_elevation"), rad(1.5) * breath);
    // Head looks around slowly, nodding a little.
    set(p, dof("neck_twist"), rad(12.0) * std::sin(w6) - 0.4 * yaw);
    set(p, dof("head_twist"), rad(6.0) * std::sin(w6 + 0.3));
    set(p, dof("neck_flexion"), rad(5.0) + rad(3.0) * std::sin(w4 + 1.0));
    set(p, dof("head_flexion"), rad(-3.0) + rad(2.0) * std::sin(w3));
    set(p, dof("head_lateral_bend"), rad(2.0) * std::sin(w12 + 2.0));
    // Arms hang about 75° below the T-pose with a slight elbow bend, drifting with the sway.
    arm(p, "l_", rad(4.0) + rad(2.0) * std::sin(w12), rad(-75.0) + rad(1.0) * breath, rad(14.0) + rad(3.0) * std::sin(w6));
    arm(p, "r_", rad(4.0) - rad(2.0) * std::sin(w12), rad(-75.0) + rad(1.0) * breath, rad(14.0) - rad(3.0) * std::sin(w6 + 0.5));
    set(p, dof("l_wrist_flexion"), rad(5.0));
    set(p, dof("r_wrist_flexion"), rad(5.0));
  }

  float leg_m_ = 0.8f;
};

// Walking around a circle of radius 1.2 m about the origin, a whole number of gait cycles per
// lap so the loop is seamless. Joint profiles follow the shape of normal gait (heel strike at
// phase 0: hip ~+26° flexed, knee nearly straight; loading response knee ~+15° at 15 %;
// push-off ankle −15° and toe extension near 60 %; swing knee peak ~60° at 72 %).
class WalkMotion final : public ProceduralMotion {
 public:
  explicit WalkMotion(const Skeleton& s) : ProceduralMotion(s, "walk", 1.0) {
    const double circumference = kTwoPi * kRadius_m;
    // Stride about 1.6 × (thigh + shin): 1.27 m on the default body, 6 cycles a lap.
    const Proportions prop = measure_proportions(s);
    const double leg = prop.thigh_m + prop.shin_m > 0.2f ? prop.thigh_m + prop.shin_m : 0.794;
    const int cycles = std::max(3, static_cast<int>(std::lround(circumference / (1.6 * leg))));
    duration_s_ = cycles * kGaitPeriod_s;
    build_height_table(static_cast<int>(std::ceil(duration_s_ * 240)));
  }

 private:
  static constexpr double kRadius_m = 1.2;
  static constexpr double kGaitPeriod_s = 1.1;

  void leg(Pose& p, const char* side, double ph) const {
    const std::string s(side);
    const double hip = 8.0 + 20.0 * std::cos(kTwoPi * (ph - 0.93));
    const double knee = 4.0 + 14.0 * bump(ph, 0.15, 0.06) + 56.0 * bump(ph, 0.72, 0.1);
    const double ankle = -6.0 * bump(ph, 0.05, 0.04) + 9.0 * bump(ph, 0.42, 0.11) - 17.0 * bump(ph, 0.62, 0.06) +
                         3.0 * bump(ph, 0.85, 0.1);
    const double toes = -28.0 * bump(ph, 0.57, 0.06);
    set(p, dof((s + "hip_flexion").c_str()), rad(hip));
    set(p, dof((s + "hip_abduction").c_str()), rad(-1.5 + 2.0 * std::cos(kTwoPi * (ph - 0.7))));
    set(p, dof((s + "knee_flexion").c_str()), rad(knee));
    set(p, dof((s + "ankle_flexion").c_str()), rad(ankle));
    set(p, dof((s + "toes_flexion").c_str()), rad(toes));
  }

  void shape(double t, Pose& p) const override {
    for (auto& v : p.dof_rad) v = 0;
    const double ph = std::fmod(t / kGaitPeriod_s, 1.0);
    const double c = std::cos(kTwoPi * ph), sn = std::sin(kTwoPi * ph);
    leg(p, "l_", ph);
    leg(p, "r_", std::fmod(ph + 0.5, 1.0));
    // Pelvis: turns forward with the leading leg, drops on the swing side, sways over the
    // stance foot.
    const double pelvis_yaw = rad(-4.0) * c;
    const double obliquity = rad(3.0) * sn;
    const double psi = kTwoPi * t / duration_s_;
    const glm::dquat heading = glm::angleAxis(-psi, glm::dvec3(0, 1, 0));
    const glm::dquat pelvis = heading * glm::angleAxis(pelvis_yaw, glm::dvec3(0, 1, 0)) *
                              glm::angleAxis(obliquity, glm::dvec3(0, 0, 1)) * glm::angleAxis(rad(3.0), glm::dvec3(1, 0, 0));
    p.root_orientation = glm::quat(glm::normalize(pelvis));
    const glm::dvec3 centre_path(kRadius_m * std::cos(psi), 0.0, kRadius_m * std::sin(psi));
    const glm::dvec3 sway = heading * glm::dvec3(0.02 * sn, 0.0, 0.0);
    p.root_position_m = glm::vec3(centre_path + sway);
    // Torso: the spine undoes the pelvic tilt, rotation and obliquity so the chest stays calm
    // and the shoulders counter-rotate a little.
    set(p, dof("spine_lower_flexion"), rad(-1.0));
    set(p, dof("spine_lower_twist"), -0.6 * pelvis_yaw);
    set(p, dof("spine_mid_twist"), -0.8 * pelvis_yaw);
    set(p, dof("spine_lower_lateral_bend"), -0.6 * obliquity);
    set(p, dof("spine_mid_lateral_bend"), -0.4 * obliquity);
    set(p, dof("neck_flexion"), rad(3.0));
    set(p, dof("head_flexion"), rad(-2.0));
    // Looking a little into the curve (the centre is on the walker's right).
    set(p, dof("neck_twist"), rad(-6.0));
    // Arms swing against the legs: the left arm forward while the left leg is back.
    const double swing_l = rad(3.0) - rad(14.0) * std::cos(kTwoPi * (ph - 0.93));
    const double swing_r = rad(3.0) - rad(14.0) * std::cos(kTwoPi * (ph + 0.5 - 0.93));
    arm(p, "l_", swing_l, rad(-78.0), rad(18.0) + 0.6 * std::max(0.0, swing_l));
    arm(p, "r_", swing_r, rad(-78.0), rad(18.0) + 0.6 * std::max(0.0, swing_r));
  }
};

}  // namespace

Result<std::unique_ptr<Motion>> make_builtin_motion(std::string_view name, const Skeleton& skeleton) {
  if (name == "idle") return std::unique_ptr<Motion>(std::make_unique<IdleMotion>(skeleton));
  if (name == "walk") return std::unique_ptr<Motion>(std::make_unique<WalkMotion>(skeleton));
  return fail(Errc::not_found, "unknown motion '" + std::string(name) + "' (built in: idle, walk)");
}

std::vector<std::string> builtin_motion_names() { return {"idle", "walk"}; }

}  // namespace mimic::avatar
