#include "calibration_fit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

#include "mimic/solver/least_squares_ik.h"

namespace mimic::solver::detail {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;
using rig::SkeletonDesc;

namespace {

constexpr float kPi = 3.14159265358979f;

void scale_desc(SkeletonDesc& d, float k) {
  for (auto& j : d.joints) {
    j.offset_m *= k;
    j.tip_m *= k;
  }
}

// Sensors strapped at a known fraction f along their segment's link (layout "all": the middle)
// mark both ends of it only together: s = near + f·(far − near). Walking up each leg from the
// toes (whose own link is short) gives ankle, knee and hip; the root sits at the skeleton's
// hip offset above the hips; from it every link's far end follows: lower back, thorax, neck,
// head, clavicles, shoulders, elbows, wrists. An error at the start alternates in sign along a
// chain instead of growing. Replaces the marks of every joint it reaches.
void mark_by_link_fractions(const Skeleton& base, const std::vector<SensorStats>& stats, const glm::quat& heading,
                            bool arms_spread, JointMarks& mark) {
  const int n = base.joint_count();
  std::vector<const SensorStats*> at(n, nullptr);
  for (const auto& st : stats) {
    const int j = base.find_joint(st.binding->segment);
    if (j >= 0 && st.binding->link_fraction > 0.05f && st.binding->link_fraction < 0.95f) at[j] = &st;
  }
  auto is_zero = [](glm::vec3 v) { return glm::length(v) < 1e-4f; };
  // The joint at the far end of each link, or through a child drawn at the segment's origin
  // when that child carries no sensor of its own (with one, the child's turn would move the far
  // end off this segment's axis, and its own sensor says where the end is).
  std::vector<int> far(n, -1);
  for (int j = 0; j < n; ++j) {
    const glm::vec3 tip = base.tip_m(j);
    if (is_zero(tip)) continue;
    for (int k = 1; k < n; ++k) {
      if (base.parent(k) == j && glm::length(base.offset_m(k) - tip) < 1e-4f) far[j] = k;
      if (base.parent(k) == j && is_zero(base.offset_m(k)) && !at[k])
        for (int g = 1; g < n; ++g)
          if (base.parent(g) == k && glm::length(base.offset_m(g) - tip) < 1e-4f) far[j] = g;
    }
  }
  std::vector<glm::vec3> pos(n);
  std::vector<uint8_t> known(n, 0);
  // Legs, upwards from the toes.
  int hips = 0;
  glm::vec3 hip_sum(0.0f), hip_offset_sum(0.0f);
  for (const char* side : {"l_", "r_"}) {
    const std::string sd(side);
    const int toes = base.find_joint(sd + "toes"), ankle = base.find_joint(sd + "ankle");
    const int knee = base.find_joint(sd + "knee"), hip = base.find_joint(sd + "hip");
    if (toes < 0 || ankle < 0 || knee < 0 || hip < 0 || !at[toes] || !at[ankle] || !at[knee] || !at[hip]) continue;
    if (far[ankle] != toes || far[knee] != ankle || far[hip] != knee) continue;
    glm::vec3 p = at[toes]->mean_pos - heading * at[toes]->binding->placement_m;
    for (int j : {toes, ankle, knee, hip}) {
      if (j != toes) {
        const float f = at[j]->binding->link_fraction;
        p = (at[j]->mean_pos - f * p) / (1.0f - f);
      }
      pos[j] = p;
      known[j] = 1;
    }
    glm::vec3 off = base.offset_m(hip);
    hip_offset_sum += sd == "l_" ? off : glm::vec3(-off.x, off.y, off.z);
    hip_sum += p;
    ++hips;
  }
  if (hips == 2) {
    const glm::vec3 o = hip_offset_sum / 2.0f;
    pos[0] = hip_sum / 2.0f - heading * glm::vec3(0.0f, o.y, o.z);
    known[0] = 1;
  }
  if (!known[0]) return;
  // Downwards through the tree: a joint drawn at its parent's origin is there; a link's far end
  // follows from its near end and its sensor. Every joint reached is a·root + c (a = ±1 for
  // mid-link sensors), so an error at the root zig-zags down each chain.
  std::vector<float> a(n, 0.0f);
  std::vector<uint8_t> from_root(n, 0);
  const glm::vec3 root0 = pos[0];
  a[0] = 1.0f, from_root[0] = 1;
  auto reach_origin_children = [&](int j) {
    for (int k = 1; k < n; ++k)
      if (!known[k] && base.parent(k) == j && is_zero(base.offset_m(k)))
        pos[k] = pos[j], known[k] = 1, a[k] = a[j], from_root[k] = from_root[j];
  };
  reach_origin_children(0);
  struct Link {
    int near, far;
  };
  std::vector<Link> links;
  for (int pass = 0; pass < n; ++pass) {
    bool more = false;
    for (int j = 0; j < n; ++j) {
      if (!known[j] || !at[j] || far[j] < 0 || known[far[j]]) continue;
      const float f = at[j]->binding->link_fraction;
      pos[far[j]] = pos[j] + (at[j]->mean_pos - pos[j]) / f;
      known[far[j]] = 1;
      a[far[j]] = a[j] * (1.0f - 1.0f / f);
      from_root[far[j]] = from_root[j];
      if (from_root[j]) links.push_back({j, far[j]});
      reach_origin_children(far[j]);
      more = true;
    }
    if (!more) break;
  }
  // The root that keeps those links nearest their stand-still directions (the skeleton's links
  // turned to the heading, at the lengths found), held towards the hips' estimate: a
  // least-squares fit in closed form, every link being linear in the root.
  if (!links.empty()) {
    constexpr float kAnchorWeight = 2.0f;
    glm::vec3 num = kAnchorWeight * root0;
    float den = kAnchorWeight;
    for (const Link& l : links) {
      const float g = a[l.far] - a[l.near];
      if (std::abs(g) < 1e-4f || is_zero(base.tip_m(l.near))) continue;
      // In an N-pose the arms hang: only the trunk's and legs' links have their zero-pose direction.
      const std::string& near_name = base.joint_name(l.near);
      if (!arms_spread &&
          (near_name.find("clavicle") != std::string::npos || near_name.find("shoulder") != std::string::npos ||
           near_name.find("elbow") != std::string::npos || near_name.find("wrist") != std::string::npos))
        continue;
      const glm::vec3 v0 = pos[l.far] - pos[l.near];
      const glm::vec3 want = glm::length(v0) * (heading * glm::normalize(base.tip_m(l.near)));
      const glm::vec3 dc = v0 - g * root0;  // v = g·root + dc
      num += g * (want - dc);
      den += g * g;
    }
    const glm::vec3 root = num / den;
    for (int j = 0; j < n; ++j)
      if (known[j] && from_root[j]) pos[j] += a[j] * (root - root0);
  }
  for (int j = 0; j < n; ++j)
    if (known[j]) mark.set_joint(j, pos[j]);
}

using PairOffsets = std::vector<std::pair<bool, glm::vec3>>;  // (left?, offset in the left side's mirror image)

glm::vec3 mirror(glm::vec3 v) { return glm::vec3(-v.x, v.y, v.z); }

// One pass of the fit, stage by stage; each stage refits the skeleton description `out_.desc`
// from the marks, and `rebuild()` turns it into the skeleton the next stage measures.
class BodyFitter {
 public:
  BodyFitter(const SkeletonDesc& base, const std::vector<SensorStats>& stats, const glm::quat& heading,
             const CalibrationOptions& opt)
      : base_skeleton_(*Skeleton::build(base)),
        stats_(stats),
        heading_(heading),
        opt_(opt),
        marks_(base_skeleton_),
        by_fraction_(base_skeleton_) {
    out_.desc = base;
  }

  void collect_marks(const SegmentRotations& segment_rot);
  void scale_to_height();
  void fit_trunk();
  void place_hips_and_shoulders();
  void fit_limbs();
  void set_posture();
  void fit_posture_to_marks();
  Fit finish();

 private:
  void rebuild() {
    s_ = *Skeleton::build(out_.desc);
    Pose p = s_.zero_pose();
    w_ = pose_world(s_, p);
  }
  glm::vec3 jpos(const Skeleton& s, const std::vector<RigidTransform>& w, const char* n) const {
    return w[s.find_joint(n)].translation;
  }
  // Where the root sits: the pelvis sensor, else hanging below the head.
  glm::vec3 root_position(const Skeleton& sk, const std::vector<RigidTransform>& wz) const {
    if (marks_.has(Landmark::pelvis)) return marks_.at(Landmark::pelvis);
    if (marks_.has(Landmark::head))
      return marks_.at(Landmark::head) - heading_ * (jpos(sk, wz, "head") - wz[0].translation);
    return glm::vec3(0, rig::standing_root_height_m(sk) + opt_.floor_y_m, 0);
  }
  // Joint position of the fitted skeleton standing at `root_`.
  glm::vec3 placed(const char* n) const { return root_ + heading_ * (jpos(s_, w_, n) - w_[0].translation); }
  // From the skeleton's own shoulder and hip (placed as fitted so far), so that the hands and
  // feet are within the fitted limbs' reach whatever the upper-limb sensors said.
  float limb_length(Landmark upper, Landmark end) const {
    if (!marks_.has(end)) return 0.0f;
    return glm::length(marks_.at(end) - placed(landmark_name(upper)));
  }
  const SensorStats* fraction_of(Landmark segment) const;
  float chain_marks(Landmark upper, Landmark mid, Landmark end);
  void set_pair_offset(const std::string& joint, const PairOffsets& measured);
  void fit_each_limb(int n_arm, int n_leg);

  const Skeleton base_skeleton_;
  const std::vector<SensorStats>& stats_;
  const glm::quat heading_;
  const CalibrationOptions& opt_;
  Fit out_;
  JointMarks marks_;        // joint positions the sensors mark
  JointMarks by_fraction_;  // … of them, those the links' fractions place (mark_by_link_fractions)
  Skeleton s_;              // the fit so far, in its zero posture (w_) with its root at root_
  std::vector<RigidTransform> w_;
  glm::vec3 root_{0.0f};
};

void BodyFitter::collect_marks(const SegmentRotations& segment_rot) {
  for (const auto& st : stats_) {
    auto it = segment_rot.find(st.binding->segment);
    const glm::quat r = it != segment_rot.end() ? it->second : heading_;
    marks_.set_joint(base_skeleton_.find_joint(st.binding->segment), st.mean_pos - r * st.binding->placement_m);
  }
  mark_by_link_fractions(base_skeleton_, stats_, heading_, opt_.pose == CalibrationPose::t_pose, by_fraction_);
  for (int j = 0; j < by_fraction_.joint_count(); ++j)
    if (by_fraction_.has_joint(j)) marks_.set_joint(j, by_fraction_.at_joint(j));
}

// Overall size from the head's height above the floor (or the feet).
void BodyFitter::scale_to_height() {
  rebuild();
  const float root_h0 = rig::standing_root_height_m(s_);
  if (!marks_.has(Landmark::head)) return;
  const float head0 = jpos(s_, w_, "head").y + root_h0;
  const float head_y = marks_.at(Landmark::head).y;
  float scale;
  if (marks_.has(Landmark::l_ankle) || marks_.has(Landmark::r_ankle)) {
    float ankle_y = 0;
    int n = 0;
    for (Landmark a : {Landmark::l_ankle, Landmark::r_ankle})
      if (marks_.has(a)) ankle_y += marks_.at(a).y, ++n;
    ankle_y /= static_cast<float>(n);
    const float ankle0 = jpos(s_, w_, "l_ankle").y + root_h0;
    scale = (head_y - ankle_y) / std::max(0.1f, head0 - ankle0);
  } else {
    scale = (head_y - opt_.floor_y_m) / std::max(0.1f, head0);
  }
  scale_desc(out_.desc, std::clamp(scale, 0.5f, 1.6f));  // children to giants
}

// Spine and neck (pelvis to chest to head), shoulder and hip width.
void BodyFitter::fit_trunk() {
  rebuild();
  const glm::vec3 up(0, 1, 0);
  const JointMarks& m = marks_;
  rig::Proportions prop = rig::measure_proportions(s_);
  if (m.has(Landmark::pelvis) && m.has(Landmark::head)) {
    const glm::vec3 pelvis = m.at(Landmark::pelvis);
    const float want = glm::dot(m.at(Landmark::head) - pelvis, up);
    if (m.has(Landmark::spine_mid) && m.has(Landmark::spine_upper)) {
      // Every link of the spine marked (one sensor per segment): take each as measured.
      const float mid_y = glm::dot(m.at(Landmark::spine_mid) - pelvis, up);
      const float upper_y = glm::dot(m.at(Landmark::spine_upper) - pelvis, up);
      prop.spine_lower_m = std::clamp(mid_y, 0.03f, 0.4f);
      prop.spine_mid_m = std::clamp(upper_y - mid_y, 0.03f, 0.4f);
      if (prop.spine_upper_m > 0)
        prop.spine_upper_m *=
            std::clamp((want - upper_y) / std::max(0.05f, prop.spine_upper_m + prop.neck_m), 0.3f, 2.5f);
      prop.neck_m = std::clamp(want - upper_y - prop.spine_upper_m, 0.03f, 0.5f);
    } else if (m.has(Landmark::spine_upper)) {
      const float lower_want = glm::dot(m.at(Landmark::spine_upper) - pelvis, up);
      const float lower_now = jpos(s_, w_, "spine_upper").y - w_[0].translation.y;
      const float upper_now = jpos(s_, w_, "head").y - jpos(s_, w_, "spine_upper").y;
      // Within bounds no body exceeds (a chest strap low on the sternum reads as a short spine).
      const float kl = std::clamp(lower_want / std::max(0.05f, lower_now), 0.3f, 2.5f);
      const float ku = std::clamp((want - lower_want) / std::max(0.05f, upper_now), 0.3f, 2.5f);
      prop.spine_lower_m *= kl, prop.spine_mid_m *= kl;
      prop.spine_upper_m *= ku, prop.neck_m *= ku;
    } else {
      const float now = jpos(s_, w_, "head").y - w_[0].translation.y;
      const float k = std::clamp(want / std::max(0.1f, now), 0.4f, 2.0f);
      prop.spine_lower_m *= k, prop.spine_mid_m *= k, prop.spine_upper_m *= k, prop.neck_m *= k;
    }
  }
  if (m.has(Landmark::l_shoulder) && m.has(Landmark::r_shoulder))
    prop.shoulder_width_m = glm::length(m.at(Landmark::l_shoulder) - m.at(Landmark::r_shoulder));
  if (m.has(Landmark::l_hip) && m.has(Landmark::r_hip))
    prop.hip_width_m = glm::length(m.at(Landmark::l_hip) - m.at(Landmark::r_hip));
  rig::apply_proportions(out_.desc, prop);
}

// Each side as its sensors show it (people are not symmetric); a side nobody measured mirrors
// the other. Offsets are given in the left side's mirror image.
void BodyFitter::set_pair_offset(const std::string& joint, const PairOffsets& measured) {
  if (measured.empty()) return;
  for (const auto& [is_left, v] : measured)
    if (glm::length(v) > 0.4f) return;  // not a body
  for (auto& jd : out_.desc.joints) {
    const bool left = jd.name == "l_" + joint, right = jd.name == "r_" + joint;
    if (!left && !right) continue;
    glm::vec3 o = measured.front().second;
    for (const auto& [is_left, v] : measured)
      if (is_left == left) o = v;
    const glm::vec3 old = jd.offset_m;
    jd.offset_m = left ? o : mirror(o);
    for (auto& par : out_.desc.joints)
      if (par.name == jd.parent && glm::length(par.tip_m - old) < 1e-5f) par.tip_m = jd.offset_m;
  }
}

// Hip and shoulder joints where the thigh and upper-arm sensors put them (relative to the pelvis
// and the chest).
void BodyFitter::place_hips_and_shoulders() {
  const glm::quat inv_h = glm::conjugate(heading_);
  const JointMarks& m = marks_;
  if (m.has(Landmark::pelvis)) {
    PairOffsets hips;
    if (m.has(Landmark::l_hip)) hips.push_back({true, inv_h * (m.at(Landmark::l_hip) - m.at(Landmark::pelvis))});
    if (m.has(Landmark::r_hip))
      hips.push_back({false, mirror(inv_h * (m.at(Landmark::r_hip) - m.at(Landmark::pelvis)))});
    set_pair_offset("hip", hips);
  }
  if (m.has(Landmark::l_shoulder) || m.has(Landmark::r_shoulder)) {
    rebuild();
    const glm::vec3 root_now = root_position(s_, w_);
    const glm::vec3 chest = m.has(Landmark::spine_upper)
                                ? m.at(Landmark::spine_upper)
                                : root_now + heading_ * (jpos(s_, w_, "spine_upper") - w_[0].translation);
    const glm::vec3 clav = s_.offset_m(s_.find_joint("l_clavicle"));
    PairOffsets shoulders;
    if (m.has(Landmark::l_shoulder)) shoulders.push_back({true, inv_h * (m.at(Landmark::l_shoulder) - chest) - clav});
    if (m.has(Landmark::r_shoulder))
      shoulders.push_back({false, mirror(inv_h * (m.at(Landmark::r_shoulder) - chest)) - clav});
    set_pair_offset("shoulder", shoulders);
  }
}

const SensorStats* BodyFitter::fraction_of(Landmark segment) const {
  for (const auto& st : stats_)
    if (st.binding->segment == landmark_name(segment) && st.binding->link_fraction > 0.05f) return &st;
  return nullptr;
}

// Sensors strapped at a known fraction of their link (layout "all": mid-link) show where each
// link ends: the elbow from the upper arm, then the wrist from the forearm (knee and ankle
// alike). Those marks replace the approximate ones. Returns the upper link's share of the limb,
// or 0 when the sensors do not show it.
float BodyFitter::chain_marks(Landmark upper, Landmark mid, Landmark end) {
  const SensorStats* su = fraction_of(upper);
  const SensorStats* sm = fraction_of(mid);
  if (!su || !sm) return 0.0f;
  const glm::vec3 a = placed(landmark_name(upper));
  glm::vec3 e = a + (su->mean_pos - a) / su->binding->link_fraction;
  glm::vec3 wpos = e + (sm->mean_pos - e) / sm->binding->link_fraction;
  if (by_fraction_.has(mid) && by_fraction_.has(end)) {
    e = marks_.at(mid), wpos = marks_.at(end);  // the whole tree's recurrence placed them already
  } else {
    marks_.set(mid, e);
    marks_.set(end, wpos);
  }
  const float lu = glm::length(e - a), ll = glm::length(wpos - e);
  return lu + ll > 0.1f ? std::clamp(lu / (lu + ll), 0.3f, 0.75f) : 0.0f;
}

// Limbs: shoulder to wrist, hip to ankle, the mean over the sides measured; the ratio between
// the two links is kept unless a sensor shows it.
void BodyFitter::fit_limbs() {
  rebuild();
  root_ = root_position(s_, w_);
  float arm = 0, leg = 0, arm_share = 0, leg_share = 0;
  int n_arm = 0, n_leg = 0, n_arm_share = 0, n_leg_share = 0;
  for (int side = 0; side < 2; ++side) {
    const Landmark shoulder = sided(side, Landmark::l_shoulder), hip = sided(side, Landmark::l_hip);
    if (float sh = chain_marks(shoulder, sided(side, Landmark::l_elbow), sided(side, Landmark::l_wrist)); sh > 0)
      arm_share += sh, ++n_arm_share;
    if (float sh = chain_marks(hip, sided(side, Landmark::l_knee), sided(side, Landmark::l_ankle)); sh > 0)
      leg_share += sh, ++n_leg_share;
    if (float l = limb_length(shoulder, sided(side, Landmark::l_wrist)); l > 0) arm += l, ++n_arm;
    if (float l = limb_length(hip, sided(side, Landmark::l_ankle)); l > 0) leg += l, ++n_leg;
  }
  rig::Proportions prop = rig::measure_proportions(s_);
  if (n_arm > 0) {
    const float total = prop.upper_arm_m + prop.forearm_m;
    const float k = std::clamp((arm / static_cast<float>(n_arm)) / total, 0.6f, 1.5f);
    // Where the elbow is along the arm a stand-still shows only through a sensor at a known
    // place on the upper arm's link; else shoulder–wrist is split as the skeleton fitted does.
    const float upper_share = n_arm_share > 0 ? arm_share / static_cast<float>(n_arm_share) : prop.upper_arm_m / total;
    prop.upper_arm_m = k * total * upper_share;
    prop.forearm_m = k * total * (1.0f - upper_share);
  }
  if (n_leg > 0) {
    const float total = prop.thigh_m + prop.shin_m;
    const float k = std::clamp((leg / static_cast<float>(n_leg)) / total, 0.6f, 1.5f);
    const float thigh_share = n_leg_share > 0 ? leg_share / static_cast<float>(n_leg_share) : prop.thigh_m / total;
    prop.thigh_m = k * total * thigh_share;
    prop.shin_m = k * total * (1.0f - thigh_share);
  }
  rig::apply_proportions(out_.desc, prop);
  if (n_arm == 2 || n_leg == 2) fit_each_limb(n_arm, n_leg);
}

// Then each side's own limb where both sides were measured (the mean is for a side nobody
// measured, and for the split when no sensor shows it).
void BodyFitter::fit_each_limb(int n_arm, int n_leg) {
  auto find_desc = [&](const std::string& n) -> rig::JointDesc* {
    for (auto& jd : out_.desc.joints)
      if (jd.name == n) return &jd;
    return nullptr;
  };
  for (int side = 0; side < 2; ++side) {
    for (const auto& [upper, mid, end, both] :
         {std::tuple{sided(side, Landmark::l_shoulder), sided(side, Landmark::l_elbow), sided(side, Landmark::l_wrist),
                     n_arm == 2},
          std::tuple{sided(side, Landmark::l_hip), sided(side, Landmark::l_knee), sided(side, Landmark::l_ankle),
                     n_leg == 2}}) {
      if (!both || !marks_.has(end)) continue;
      // With the middle joint marked too, each link as marked (a bent limb's links are longer
      // than the straight line between its ends); else the straight line, split as before.
      const bool mid_marked = marks_.has(mid) && fraction_of(upper) && fraction_of(mid);
      const float upper_m = mid_marked ? glm::length(marks_.at(mid) - placed(landmark_name(upper))) : 0.0f;
      const float lower_m = mid_marked ? glm::length(marks_.at(end) - marks_.at(mid)) : 0.0f;
      const float total =
          mid_marked ? std::clamp(upper_m + lower_m, 0.2f, 1.5f) : std::clamp(limb_length(upper, end), 0.2f, 1.5f);
      const float share = mid_marked && upper_m + lower_m > 0.1f ? upper_m / (upper_m + lower_m) : -1.0f;
      rig::JointDesc* jm = find_desc(landmark_name(mid));
      rig::JointDesc* je = find_desc(landmark_name(end));
      if (!jm || !je || glm::length(jm->offset_m) < 1e-4f || glm::length(je->offset_m) < 1e-4f) continue;
      const float lm = glm::length(jm->offset_m), le = glm::length(je->offset_m);
      const float sh = share > 0.25f && share < 0.8f ? share : lm / (lm + le);
      for (auto [jd, want] : {std::pair{jm, total * sh}, std::pair{je, total * (1.0f - sh)}}) {
        const glm::vec3 old = jd->offset_m;
        jd->offset_m = old * (want / glm::length(old));
        for (auto& par : out_.desc.joints)
          if (par.name == jd->parent && glm::length(par.tip_m - old) < 1e-5f) par.tip_m = jd->offset_m;
      }
    }
  }
}

// The calibration posture: nominal, with the limbs pointing where the sensors say.
void BodyFitter::set_posture() {
  rebuild();
  root_ = root_position(s_, w_);
  out_.pose = s_.zero_pose();
  out_.pose.root_orientation = heading_;
  out_.pose.root_position_m = root_ - heading_ * s_.offset_m(0);
  const glm::quat inv_heading = glm::conjugate(heading_);
  auto set = [&](const std::string& dof, float v) {
    const int d = s_.find_dof(dof);
    if (d >= 0) out_.pose.dof_rad[d] = std::clamp(v, s_.dof(d).min_rad, s_.dof(d).max_rad);
  };
  for (int side = 0; side < 2; ++side) {
    const std::string sd(side == 0 ? "l_" : "r_");
    const float side_sign = side == 0 ? 1.0f : -1.0f;
    if (opt_.pose == CalibrationPose::n_pose) set(sd + "shoulder_abduction", -80.0f * kPi / 180.0f);
    if (const Landmark wrist = sided(side, Landmark::l_wrist); marks_.has(wrist)) {
      // From the fitted skeleton's own shoulder, so the fitted hand lands on the hand's mark.
      const glm::vec3 a = placed(landmark_name(sided(side, Landmark::l_shoulder)));
      const glm::vec3 d = glm::normalize(inv_heading * (marks_.at(wrist) - a));
      const float abd = std::asin(std::clamp(d.y, -1.0f, 1.0f));
      set(sd + "shoulder_abduction", abd);
      if (std::cos(abd) > 0.3f) set(sd + "shoulder_flexion", std::atan2(d.z, side_sign * d.x));
    }
    if (const Landmark ankle = sided(side, Landmark::l_ankle); marks_.has(ankle)) {
      const glm::vec3 h = placed(landmark_name(sided(side, Landmark::l_hip)));
      const glm::vec3 d = glm::normalize(inv_heading * (marks_.at(ankle) - h));
      set(sd + "hip_abduction", std::asin(std::clamp(side_sign * d.x, -1.0f, 1.0f)));
      set(sd + "hip_flexion", std::atan2(d.z, -d.y));
    }
  }
}

// The posture itself, where enough joints are marked (pelvis and feet, thighs, one sensor per
// segment): the joints as close to their marks as the fitted skeleton's links allow, the rest
// held nominal. A segment whose turning moves no mark keeps the stand-still's nominal
// orientation: in the world (head up, feet flat, thorax upright), or, for hands and toes, in
// line with the forearm and the foot (a world target there would pull the leg off its marks).
void BodyFitter::fit_posture_to_marks() {
  const Skeleton& s = s_;
  std::vector<IkTarget> targets;
  std::vector<uint8_t> moves_a_mark(static_cast<size_t>(s.joint_count()), 0);
  for (int j = 1; j < s.joint_count(); ++j) {
    if (!marks_.has_joint(j) || s.dof_begin(s.parent(j)) == s.dof_end(s.parent(j))) continue;
    // The toes: a foot turned beyond the ankle's limits (as stand-stills sometimes show) would
    // pull the whole leg off its marks to reach them.
    if (s.joint_name(j).find("toes") != std::string::npos) continue;
    targets.push_back(IkTarget{j, marks_.at_joint(j), {1, 0, 0, 0}, 100.0f, 0.0f});
    if (glm::length(s.offset_m(j)) > 1e-4f) moves_a_mark[static_cast<size_t>(s.parent(j))] = 1;
  }
  const size_t position_targets = targets.size();
  // Head and hands alone leave the trunk's bend unknown: the nominal posture is the better guess.
  constexpr size_t kMinMarks = 5;
  if (position_targets < kMinMarks) return;
  std::vector<uint8_t> held(static_cast<size_t>(s.dof_count()), 0);
  for (int j = 1; j < s.joint_count(); ++j) {
    if (moves_a_mark[static_cast<size_t>(j)] || s.dof_begin(j) == s.dof_end(j)) continue;
    const std::string& name = s.joint_name(j);
    if (name.find("wrist") != std::string::npos || name.find("toes") != std::string::npos) {
      for (int d = s.dof_begin(j); d < s.dof_end(j); ++d)
        held[static_cast<size_t>(d)] = 1;  // in line with the forearm, foot
    } else {
      targets.push_back(IkTarget{j, {}, heading_, 0.0f, 3.0f});
    }
  }
  // Twists about a link move no mark on it; they stay nominal.
  std::vector<int> dofs;
  for (int d = 0; d < s.dof_count(); ++d) {
    const std::string& name = s.dof(d).name;
    // Elbows and knees straight, as the stand-still asks: free, they folded to take up what a
    // leaning trunk left over and turned the hands' forearms off their arms.
    if (name.find("elbow_flexion") != std::string::npos || name.find("knee_flexion") != std::string::npos) continue;
    if (name.find("twist") == std::string::npos && !held[static_cast<size_t>(d)]) dofs.push_back(d);
  }
  const std::vector<float> prior = out_.pose.dof_rad;
  LeastSquaresIkContext ctx(s, s.dof_count(), static_cast<int>(targets.size()));
  LeastSquaresIkJob job;
  job.skeleton = &s;
  job.dofs = dofs;
  job.targets = targets;
  job.prior_rad = prior;
  job.prior_weight = 0.3f;
  job.max_iterations = 60;
  job.step_tolerance = 1e-5f;
  job.context = &ctx;
  job.pose = &out_.pose;
  job.Run();
}

// Height and floor from the head's and a foot's marks.
Fit BodyFitter::finish() {
  const Skeleton& s = s_;
  const float head_top = marks_.has(Landmark::head) ? marks_.at(Landmark::head).y + 0.12f : 0.0f;
  float floor = opt_.floor_y_m;
  if (marks_.has(Landmark::l_ankle) || marks_.has(Landmark::r_ankle)) {
    const glm::vec3 a = marks_.has(Landmark::l_ankle) ? marks_.at(Landmark::l_ankle) : marks_.at(Landmark::r_ankle);
    const auto wp = pose_world(s, out_.pose);
    floor = a.y - (wp[s.find_joint("l_ankle")].translation.y -
                   (out_.pose.root_position_m.y - rig::standing_root_height_m(s)));
  }
  out_.height_m = marks_.has(Landmark::head) ? head_top - floor : 0.0f;
  out_.floor_y_m = floor;
  return std::move(out_);
}

}  // namespace

std::vector<RigidTransform> pose_world(const Skeleton& s, const Pose& pose) {
  std::vector<RigidTransform> w(s.joint_count());
  rig::forward_kinematics(s, pose, w);
  return w;
}

float angle_deg(const glm::quat& a, const glm::quat& b) {
  const glm::quat d = a * glm::conjugate(b);
  return glm::degrees(2.0f * std::asin(std::min(1.0f, glm::length(glm::vec3(d.x, d.y, d.z)))));
}

Fit fit_body(const SkeletonDesc& base, const std::vector<SensorStats>& stats, const glm::quat& heading,
             const SegmentRotations& segment_rot, const CalibrationOptions& opt) {
  BodyFitter fitter(base, stats, heading, opt);
  fitter.collect_marks(segment_rot);
  fitter.scale_to_height();
  fitter.fit_trunk();
  fitter.place_hips_and_shoulders();
  fitter.fit_limbs();
  fitter.set_posture();
  fitter.fit_posture_to_marks();
  return fitter.finish();
}

}  // namespace mimic::solver::detail
