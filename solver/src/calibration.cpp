#include "mimic/solver/calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <glm/gtx/norm.hpp>
#include <nlohmann/json.hpp>

#include "mimic/core/file.h"
#include "mimic/solver/least_squares_ik.h"

namespace mimic::solver {

using rig::Pose;
using rig::RigidTransform;
using rig::Skeleton;
using rig::SkeletonDesc;

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kMaxFitPasses = 4;  // fits of the body to the stand-still, at most

struct SensorStats {
  const SensorBinding* binding = nullptr;
  int count = 0;
  glm::dvec3 sum{0.0};
  glm::dquat qsum{0, 0, 0, 0};
  glm::quat first{1, 0, 0, 0};
  glm::vec3 mean_pos{0.0f};
  glm::quat mean_rot{1, 0, 0, 0};
  float max_dist_m = 0, max_angle_deg = 0;
};

float angle_deg(const glm::quat& a, const glm::quat& b) {
  const glm::quat d = a * glm::conjugate(b);
  return glm::degrees(2.0f * std::asin(std::min(1.0f, glm::length(glm::vec3(d.x, d.y, d.z)))));
}


std::string fmt(float v, const char* f = "%.1f") {
  char b[32];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// Joint world positions of a skeleton posed at `pose`.
std::vector<RigidTransform> pose_world(const Skeleton& s, const Pose& pose) {
  std::vector<RigidTransform> w(s.joint_count());
  rig::forward_kinematics(s, pose, w);
  return w;
}

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
                            bool arms_spread, std::map<std::string, glm::vec3>& mark) {
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
  struct Link { int near, far; };
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
      if (!arms_spread && (near_name.find("clavicle") != std::string::npos || near_name.find("shoulder") != std::string::npos ||
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
    if (known[j]) mark[base.joint_name(j)] = pos[j];
}

struct Fit {
  SkeletonDesc desc;
  Pose pose;
  float height_m = 0;
  float floor_y_m = 0;
  std::map<std::string, glm::vec3> mark;  // joint positions the sensors marked
};

// One pass of the fit. `segment_rot` gives, per joint name, the rotation used to turn a sensor's
// instructed placement into world space (the heading on the first pass, the fitted posture's
// segment rotations on the second).
Fit fit_body(const SkeletonDesc& base, const std::vector<SensorStats>& stats, const glm::quat& heading,
             const std::map<std::string, glm::quat>& segment_rot, const CalibrationOptions& opt) {
  Fit out;
  out.desc = base;
  const glm::vec3 up(0, 1, 0);
  // Joint positions the sensors mark.
  std::map<std::string, glm::vec3> mark;
  for (const auto& st : stats) {
    auto it = segment_rot.find(st.binding->segment);
    const glm::quat r = it != segment_rot.end() ? it->second : heading;
    mark[st.binding->segment] = st.mean_pos - r * st.binding->placement_m;
  }
  std::map<std::string, glm::vec3> by_fraction;
  mark_by_link_fractions(*Skeleton::build(base), stats, heading, opt.pose == CalibrationPose::t_pose, by_fraction);
  for (const auto& [name, at] : by_fraction) mark[name] = at;
  auto has = [&](const char* n) { return mark.count(n) > 0; };
  auto build = [&]() { return *Skeleton::build(out.desc); };
  auto zero_world = [&](const Skeleton& s) {
    Pose p = s.zero_pose();
    return pose_world(s, p);
  };
  auto jpos = [&](const Skeleton& s, const std::vector<RigidTransform>& w, const char* n) {
    return w[s.find_joint(n)].translation;
  };

  // Overall size from the head's height above the floor (or the feet).
  Skeleton s = build();
  auto w = zero_world(s);
  const float root_h0 = rig::standing_root_height_m(s);
  if (has("head")) {
    const float head0 = jpos(s, w, "head").y + root_h0;
    float scale;
    if (has("l_ankle") || has("r_ankle")) {
      float ankle_y = 0;
      int n = 0;
      for (const char* a : {"l_ankle", "r_ankle"})
        if (has(a)) ankle_y += mark[a].y, ++n;
      ankle_y /= static_cast<float>(n);
      const float ankle0 = jpos(s, w, "l_ankle").y + root_h0;
      scale = (mark["head"].y - ankle_y) / std::max(0.1f, head0 - ankle0);
    } else {
      scale = (mark["head"].y - opt.floor_y_m) / std::max(0.1f, head0);
    }
    scale_desc(out.desc, std::clamp(scale, 0.5f, 1.6f));  // children to giants
  }
  s = build();
  w = zero_world(s);
  rig::Proportions prop = rig::measure_proportions(s);

  // Where the root sits: the pelvis sensor, else hanging below the head.
  auto root_position = [&](const Skeleton& sk, const std::vector<RigidTransform>& wz) {
    if (has("pelvis")) return mark["pelvis"];
    if (has("head")) return mark["head"] - heading * (jpos(sk, wz, "head") - wz[0].translation);
    return glm::vec3(0, rig::standing_root_height_m(sk) + opt.floor_y_m, 0);
  };

  // Spine and neck: pelvis to chest to head.
  if (has("pelvis") && has("head")) {
    const float want = glm::dot(mark["head"] - mark["pelvis"], up);
    if (has("spine_mid") && has("spine_upper")) {
      // Every link of the spine marked (one sensor per segment): take each as measured.
      const float mid_y = glm::dot(mark["spine_mid"] - mark["pelvis"], up);
      const float upper_y = glm::dot(mark["spine_upper"] - mark["pelvis"], up);
      prop.spine_lower_m = std::clamp(mid_y, 0.03f, 0.4f);
      prop.spine_mid_m = std::clamp(upper_y - mid_y, 0.03f, 0.4f);
      if (prop.spine_upper_m > 0) prop.spine_upper_m *= std::clamp((want - upper_y) / std::max(0.05f, prop.spine_upper_m + prop.neck_m), 0.3f, 2.5f);
      prop.neck_m = std::clamp(want - upper_y - prop.spine_upper_m, 0.03f, 0.5f);
    } else if (has("spine_upper")) {
      const float lower_want = glm::dot(mark["spine_upper"] - mark["pelvis"], up);
      const float lower_now = jpos(s, w, "spine_upper").y - w[0].translation.y;
      const float upper_now = jpos(s, w, "head").y - jpos(s, w, "spine_upper").y;
      // Within bounds no body exceeds (a chest strap low on the sternum reads as a short spine).
      const float kl = std::clamp(lower_want / std::max(0.05f, lower_now), 0.3f, 2.5f);
      const float ku = std::clamp((want - lower_want) / std::max(0.05f, upper_now), 0.3f, 2.5f);
      prop.spine_lower_m *= kl, prop.spine_mid_m *= kl;
      prop.spine_upper_m *= ku, prop.neck_m *= ku;
    } else {
      const float now = jpos(s, w, "head").y - w[0].translation.y;
      const float k = std::clamp(want / std::max(0.1f, now), 0.4f, 2.0f);
      prop.spine_lower_m *= k, prop.spine_mid_m *= k, prop.spine_upper_m *= k, prop.neck_m *= k;
    }
  }
  if (has("l_shoulder") && has("r_shoulder")) prop.shoulder_width_m = glm::length(mark["l_shoulder"] - mark["r_shoulder"]);
  if (has("l_hip") && has("r_hip")) prop.hip_width_m = glm::length(mark["l_hip"] - mark["r_hip"]);
  rig::apply_proportions(out.desc, prop);
  // Hip and shoulder joints where the thigh and upper-arm sensors put them (relative to the
  // pelvis and the chest), averaged over both sides to keep the skeleton symmetric.
  const glm::quat inv_h = glm::conjugate(heading);
  auto mirror = [](glm::vec3 v) { return glm::vec3(-v.x, v.y, v.z); };
  // Each side as its sensors show it (people are not symmetric); a side nobody measured mirrors
  // the other. Offsets are given in the left side's mirror image.
  auto set_pair_offset = [&](const std::string& joint, const std::vector<std::pair<bool, glm::vec3>>& measured) {
    if (measured.empty()) return;
    for (const auto& [is_left, v] : measured)
      if (glm::length(v) > 0.4f) return;  // not a body
    for (auto& jd : out.desc.joints) {
      const bool left = jd.name == "l_" + joint, right = jd.name == "r_" + joint;
      if (!left && !right) continue;
      glm::vec3 o = measured.front().second;
      for (const auto& [is_left, v] : measured)
        if (is_left == left) o = v;
      const glm::vec3 old = jd.offset_m;
      jd.offset_m = left ? o : mirror(o);
      for (auto& par : out.desc.joints)
        if (par.name == jd.parent && glm::length(par.tip_m - old) < 1e-5f) par.tip_m = jd.offset_m;
    }
  };
  if (has("pelvis")) {
    std::vector<std::pair<bool, glm::vec3>> hips;
    if (has("l_hip")) hips.push_back({true, inv_h * (mark["l_hip"] - mark["pelvis"])});
    if (has("r_hip")) hips.push_back({false, mirror(inv_h * (mark["r_hip"] - mark["pelvis"]))});
    set_pair_offset("hip", hips);
  }
  if (has("l_shoulder") || has("r_shoulder")) {
    Skeleton sk = build();
    const auto wz = zero_world(sk);
    const glm::vec3 root_now = root_position(sk, wz);
    auto placed_now = [&](const char* n) { return root_now + heading * (jpos(sk, wz, n) - wz[0].translation); };
    const glm::vec3 chest = has("spine_upper") ? mark["spine_upper"] : placed_now("spine_upper");
    const glm::vec3 clav = sk.offset_m(sk.find_joint("l_clavicle"));
    std::vector<std::pair<bool, glm::vec3>> shoulders;
    if (has("l_shoulder")) shoulders.push_back({true, inv_h * (mark["l_shoulder"] - chest) - clav});
    if (has("r_shoulder")) shoulders.push_back({false, mirror(inv_h * (mark["r_shoulder"] - chest)) - clav});
    set_pair_offset("shoulder", shoulders);
  }
  s = build();
  w = zero_world(s);

  // Limbs: shoulder to wrist, hip to ankle; the ratio between the two links is kept.
  glm::vec3 root = root_position(s, w);
  auto placed = [&](const char* n) {  // joint position of the fitted skeleton standing at `root`
    return root + heading * (jpos(s, w, n) - w[0].translation);
  };
  // From the skeleton's own shoulder and hip (placed as fitted so far), so that the hands and
  // feet are within the fitted limbs' reach whatever the upper-limb sensors said.
  auto limb_length = [&](const char* upper, const char* end) -> float {
    if (!has(end)) return 0.0f;
    return glm::length(mark[end] - placed(upper));
  };
  float arm = 0, leg = 0, arm_share = 0, leg_share = 0;
  int n_arm = 0, n_leg = 0, n_arm_share = 0, n_leg_share = 0;
  // Sensors strapped at a known fraction of their link (layout "all": mid-link) show where each
  // link ends: the elbow from the upper arm, then the wrist from the forearm (knee and ankle
  // alike). Those marks replace the approximate ones.
  auto fraction_of = [&](const std::string& seg) -> const SensorStats* {
    for (const auto& st : stats)
      if (st.binding->segment == seg && st.binding->link_fraction > 0.05f) return &st;
    return nullptr;
  };
  auto chain_marks = [&](const std::string& upper, const std::string& mid, const std::string& end) -> float {
    const SensorStats* su = fraction_of(upper);
    const SensorStats* sm = fraction_of(mid);
    if (!su || !sm) return 0.0f;
    const glm::vec3 a = placed(upper.c_str());
    glm::vec3 e = a + (su->mean_pos - a) / su->binding->link_fraction;
    glm::vec3 wpos = e + (sm->mean_pos - e) / sm->binding->link_fraction;
    if (by_fraction.count(mid) && by_fraction.count(end)) {
      e = mark[mid], wpos = mark[end];  // the whole tree's recurrence placed them already
    } else {
      mark[mid] = e;
      mark[end] = wpos;
    }
    const float lu = glm::length(e - a), ll = glm::length(wpos - e);
    return lu + ll > 0.1f ? std::clamp(lu / (lu + ll), 0.3f, 0.75f) : 0.0f;
  };
  for (const char* side : {"l_", "r_"}) {
    const std::string sd(side);
    if (float sh = chain_marks(sd + "shoulder", sd + "elbow", sd + "wrist"); sh > 0) arm_share += sh, ++n_arm_share;
    if (float sh = chain_marks(sd + "hip", sd + "knee", sd + "ankle"); sh > 0) leg_share += sh, ++n_leg_share;
    if (float l = limb_length((sd + "shoulder").c_str(), (sd + "wrist").c_str()); l > 0) arm += l, ++n_arm;
    if (float l = limb_length((sd + "hip").c_str(), (sd + "ankle").c_str()); l > 0) leg += l, ++n_leg;
  }
  prop = rig::measure_proportions(s);
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
  rig::apply_proportions(out.desc, prop);
  // Then each side's own limb where both sides were measured (the mean above is for a side
  // nobody measured, and for the split when no sensor shows it).
  if (n_arm == 2 || n_leg == 2)
    for (const char* side : {"l_", "r_"}) {
      const std::string sd(side);
      for (const auto& [upper, mid, end, both] :
           {std::tuple{sd + "shoulder", sd + "elbow", sd + "wrist", n_arm == 2},
            std::tuple{sd + "hip", sd + "knee", sd + "ankle", n_leg == 2}}) {
        if (!both || !has(end.c_str())) continue;
        // With the middle joint marked too, each link as marked (a bent limb's links are longer
        // than the straight line between its ends); else the straight line, split as before.
        const bool mid_marked = has(mid.c_str()) && fraction_of(upper) && fraction_of(mid);
        const float upper_m = mid_marked ? glm::length(mark[mid] - placed(upper.c_str())) : 0.0f;
        const float lower_m = mid_marked ? glm::length(mark[end] - mark[mid]) : 0.0f;
        const float total = mid_marked ? std::clamp(upper_m + lower_m, 0.2f, 1.5f)
                                       : std::clamp(limb_length(upper.c_str(), end.c_str()), 0.2f, 1.5f);
        const float share = mid_marked && upper_m + lower_m > 0.1f ? upper_m / (upper_m + lower_m) : -1.0f;
        auto find_desc = [&](const std::string& n) -> rig::JointDesc* {
          for (auto& jd : out.desc.joints)
            if (jd.name == n) return &jd;
          return nullptr;
        };
        rig::JointDesc* jm = find_desc(mid);
        rig::JointDesc* je = find_desc(end);
        if (!jm || !je || glm::length(jm->offset_m) < 1e-4f || glm::length(je->offset_m) < 1e-4f) continue;
        const float lm = glm::length(jm->offset_m), le = glm::length(je->offset_m);
        const float sh = share > 0.25f && share < 0.8f ? share : lm / (lm + le);
        for (auto [jd, want] : {std::pair{jm, total * sh}, std::pair{je, total * (1.0f - sh)}}) {
          const glm::vec3 old = jd->offset_m;
          jd->offset_m = old * (want / glm::length(old));
          for (auto& par : out.desc.joints)
            if (par.name == jd->parent && glm::length(par.tip_m - old) < 1e-5f) par.tip_m = jd->offset_m;
        }
      }
    }
  s = build();
  w = zero_world(s);
  root = root_position(s, w);

  // The calibration posture: nominal, with the limbs pointing where the sensors say.
  out.pose = s.zero_pose();
  out.pose.root_orientation = heading;
  out.pose.root_position_m = root - heading * s.offset_m(0);
  const glm::quat inv_heading = glm::conjugate(heading);
  auto set = [&](const std::string& dof, float v) {
    const int d = s.find_dof(dof);
    if (d >= 0) out.pose.dof_rad[d] = std::clamp(v, s.dof(d).min_rad, s.dof(d).max_rad);
  };
  for (const char* side : {"l_", "r_"}) {
    const std::string sd(side);
    const float side_sign = sd == "l_" ? 1.0f : -1.0f;
    if (opt.pose == CalibrationPose::n_pose) set(sd + "shoulder_abduction", -80.0f * kPi / 180.0f);
    if (has((sd + "wrist").c_str())) {
      // From the fitted skeleton's own shoulder, so the fitted hand lands on the hand's mark.
      const glm::vec3 a = placed((sd + "shoulder").c_str());
      const glm::vec3 d = glm::normalize(inv_heading * (mark[sd + "wrist"] - a));
      const float abd = std::asin(std::clamp(d.y, -1.0f, 1.0f));
      set(sd + "shoulder_abduction", abd);
      if (std::cos(abd) > 0.3f) set(sd + "shoulder_flexion", std::atan2(d.z, side_sign * d.x));
    }
    if (has((sd + "ankle").c_str())) {
      const glm::vec3 h = placed((sd + "hip").c_str());
      const glm::vec3 d = glm::normalize(inv_heading * (mark[sd + "ankle"] - h));
      set(sd + "hip_abduction", std::asin(std::clamp(side_sign * d.x, -1.0f, 1.0f)));
      set(sd + "hip_flexion", std::atan2(d.z, -d.y));
    }
  }
  // The posture itself, where enough joints are marked (pelvis and feet, thighs, one sensor per
  // segment): the joints as close to their marks as the fitted skeleton's links allow, the
  // rest held nominal. A segment whose turning moves no mark keeps the stand-still's nominal
  // orientation: in the world (head up, feet flat, thorax upright), or, for hands and toes, in
  // line with the forearm and the foot (a world target there would pull the leg off its marks).
  {
    std::vector<IkTarget> targets;
    std::vector<uint8_t> moves_a_mark(static_cast<size_t>(s.joint_count()), 0);
    for (int j = 1; j < s.joint_count(); ++j) {
      auto it = mark.find(s.joint_name(j));
      if (it == mark.end() || s.dof_begin(s.parent(j)) == s.dof_end(s.parent(j))) continue;
      // The toes: a foot turned beyond the ankle's limits (as stand-stills sometimes show) would
      // pull the whole leg off its marks to reach them.
      if (s.joint_name(j).find("toes") != std::string::npos) continue;
      targets.push_back(IkTarget{j, it->second, {1, 0, 0, 0}, 100.0f, 0.0f});
      if (glm::length(s.offset_m(j)) > 1e-4f) moves_a_mark[static_cast<size_t>(s.parent(j))] = 1;
    }
    const size_t position_targets = targets.size();
    // Head and hands alone leave the trunk's bend unknown: the nominal posture is the better guess.
    constexpr size_t kMinMarks = 5;
    std::vector<uint8_t> held(static_cast<size_t>(s.dof_count()), 0);
    for (int j = 1; j < s.joint_count() && position_targets >= kMinMarks; ++j) {
      if (moves_a_mark[static_cast<size_t>(j)] || s.dof_begin(j) == s.dof_end(j)) continue;
      const std::string& name = s.joint_name(j);
      if (name.find("wrist") != std::string::npos || name.find("toes") != std::string::npos) {
        for (int d = s.dof_begin(j); d < s.dof_end(j); ++d) held[static_cast<size_t>(d)] = 1;  // in line with the forearm, foot
      } else {
        targets.push_back(IkTarget{j, {}, heading, 0.0f, 3.0f});
      }
    }
    if (position_targets >= kMinMarks) {
      // Twists about a link move no mark on it; they stay nominal.
      std::vector<int> dofs;
      for (int d = 0; d < s.dof_count(); ++d) {
        const std::string& name = s.dof(d).name;
        // Elbows and knees straight, as the stand-still asks: free, they folded to take up
        // what a leaning trunk left over and turned the hands' forearms off their arms.
        if (name.find("elbow_flexion") != std::string::npos || name.find("knee_flexion") != std::string::npos) continue;
        if (name.find("twist") == std::string::npos && !held[static_cast<size_t>(d)])
          dofs.push_back(d);
      }
      const std::vector<float> prior = out.pose.dof_rad;
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
      job.pose = &out.pose;
      job.Run();
    }
  }
  const float head_top = has("head") ? mark["head"].y + 0.12f : 0.0f;
  float floor = opt.floor_y_m;
  if (has("l_ankle") || has("r_ankle")) {
    const glm::vec3 a = has("l_ankle") ? mark["l_ankle"] : mark["r_ankle"];
    const auto wp = pose_world(s, out.pose);
    floor = a.y - (wp[s.find_joint("l_ankle")].translation.y - (out.pose.root_position_m.y - rig::standing_root_height_m(s)));
  }
  out.height_m = has("head") ? head_top - floor : 0.0f;
  out.floor_y_m = floor;
  out.mark = mark;
  return out;
}

}  // namespace

SkeletonDesc tracking_skeleton_desc(const SkeletonDesc& base) {
  SkeletonDesc d = base;
  auto find = [&](const std::string& name) -> rig::JointDesc* {
    for (auto& j : d.joints)
      if (j.name == name) return &j;
    return nullptr;
  };
  // Moves joint `name` onto its parent's origin; its children keep their positions.
  auto collapse = [&](const std::string& name) {
    rig::JointDesc* j = find(name);
    if (!j) return glm::vec3(0.0f);
    const glm::vec3 o = j->offset_m;
    j->offset_m = glm::vec3(0.0f);
    for (auto& c : d.joints)
      if (c.parent == name) c.offset_m += o;
    if (rig::JointDesc* p = find(j->parent); p && glm::length2(p->tip_m - o) < 1e-10f) p->tip_m = glm::vec3(0.0f);
    return o;
  };
  collapse("spine_lower");
  if (rig::JointDesc* sl = find("spine_lower"); sl)
    if (rig::JointDesc* sm = find("spine_mid"); sm)
      if (rig::JointDesc* pv = find("pelvis"); pv) sl->tip_m = pv->tip_m = sm->offset_m;
  for (const char* side : {"l_", "r_"}) {
    const std::string s(side);
    collapse(s + "clavicle");
    if (rig::JointDesc* c = find(s + "clavicle"); c)
      if (rig::JointDesc* sh = find(s + "shoulder"); sh) c->tip_m = sh->offset_m;
  }
  // Proportions of what no sensor of a sparse layout marks, relative to the leg (hip centre to
  // ankle): the means of the six CMU subjects of the reference clips (their skeletons put the
  // thorax, neck and shoulders lower than anatomical tables do, and the upper arm longer).
  const float leg = [&] {
    const rig::JointDesc* k = find("l_knee");
    const rig::JointDesc* a = find("l_ankle");
    return k && a ? glm::length(k->offset_m) + glm::length(a->offset_m) : 0.794f;
  }();
  auto set_offset = [&](const std::string& name, glm::vec3 offset) {
    rig::JointDesc* j = find(name);
    if (!j) return;
    if (rig::JointDesc* p = find(j->parent); p && glm::length2(p->tip_m - j->offset_m) < 1e-10f) p->tip_m = offset;
    j->offset_m = offset;
  };
  if (rig::JointDesc* n = find("neck"); n && find("neck_upper") && find("head") && find("spine_upper")) {
    set_offset("spine_mid", {0.0f, 0.149f * leg, 0.0f});
    set_offset("spine_upper", {0.0f, 0.149f * leg, 0.0f});
    // The neck pivots at the top of the thorax; two equal links up to the head joint.
    n->offset_m = glm::vec3(0.0f);
    set_offset("neck_upper", {0.0f, 0.100f * leg, 0.0f});
    set_offset("head", {0.0f, 0.100f * leg, 0.0f});
    find("spine_upper")->tip_m = n->tip_m = find("neck_upper")->offset_m;
    find("neck_upper")->tip_m = find("head")->offset_m;
    if (rig::JointDesc* sl = find("spine_lower"); sl) sl->tip_m = find("spine_mid")->offset_m;
    if (rig::JointDesc* pv = find("pelvis"); pv) pv->tip_m = find("spine_mid")->offset_m;
  }
  for (const char* side : {"l_", "r_"}) {
    const std::string sd(side);
    const float x = sd == "l_" ? 1.0f : -1.0f;
    set_offset(sd + "shoulder", {x * 0.218f * leg, 0.068f * leg, -0.016f * leg});
    if (rig::JointDesc* c = find(sd + "clavicle"); c)
      if (const rig::JointDesc* sh = find(sd + "shoulder"); sh) c->tip_m = sh->offset_m;
    rig::JointDesc* e = find(sd + "elbow");
    rig::JointDesc* w = find(sd + "wrist");
    if (e && w) {  // shoulder to wrist 0.569 of the leg, 61 % of it above the elbow
      set_offset(sd + "elbow", glm::normalize(e->offset_m) * (0.611f * 0.569f * leg));
      set_offset(sd + "wrist", glm::normalize(w->offset_m) * (0.389f * 0.569f * leg));
    }
    // Hip centres a hand's width below the root and a little forward of it.
    if (rig::JointDesc* hp = find(sd + "hip"); hp) hp->offset_m = glm::vec3(x * 0.112f * leg, -0.120f * leg, 0.045f * leg);
  }
  return d;
}

const char* calibration_pose_name(CalibrationPose pose) {
  return pose == CalibrationPose::n_pose ? "npose" : "tpose";
}

Result<CalibrationPose> parse_calibration_pose(std::string_view name) {
  if (name == "tpose" || name == "t") return CalibrationPose::t_pose;
  if (name == "npose" || name == "n") return CalibrationPose::n_pose;
  return fail(Errc::invalid_argument, "unknown calibration pose '" + std::string(name) + "' (tpose or npose)");
}

Result<Calibration> calibrate(const SkeletonDesc& base, const SensorLayout& layout,
                              std::span<const devices::SensorSample> capture, const CalibrationOptions& opt) {
  auto base_skeleton = Skeleton::build(base);
  if (!base_skeleton) return tl::unexpected(base_skeleton.error());
  if (layout.bindings.empty()) return fail(Errc::invalid_argument, "calibration: the layout has no sensors");
  for (const auto& b : layout.bindings)
    if (base_skeleton->find_joint(b.segment) < 0)
      return fail(Errc::not_found, "calibration: sensor '" + b.name + "' is on unknown segment '" + b.segment + "'");

  // Per-sensor mean pose and spread.
  std::vector<SensorStats> stats(layout.bindings.size());
  std::map<uint16_t, size_t> slot;
  for (size_t i = 0; i < layout.bindings.size(); ++i) {
    stats[i].binding = &layout.bindings[i];
    slot[layout.bindings[i].sensor] = i;
  }
  double t0 = 0, t1 = 0;
  int used = 0;
  auto finite = [](const devices::SensorSample& s) {
    return std::isfinite(s.position_m.x) && std::isfinite(s.position_m.y) && std::isfinite(s.position_m.z) &&
           std::isfinite(s.orientation.w) && std::isfinite(s.orientation.x) && std::isfinite(s.orientation.y) &&
           std::isfinite(s.orientation.z) && glm::dot(s.orientation, s.orientation) > 0.25f;
  };
  for (const auto& smp : capture) {
    if (!(smp.flags & devices::kSampleValid) || !finite(smp)) continue;
    auto it = slot.find(smp.sensor);
    if (it == slot.end()) continue;
    SensorStats& st = stats[it->second];
    const glm::quat q = glm::normalize(smp.orientation);
    if (st.count == 0) st.first = q;
    const glm::quat aligned = glm::dot(q, st.first) < 0 ? -q : q;
    st.sum += glm::dvec3(smp.position_m);
    st.qsum = glm::dquat(st.qsum.w + aligned.w, st.qsum.x + aligned.x, st.qsum.y + aligned.y, st.qsum.z + aligned.z);
    ++st.count;
    if (used == 0) t0 = t1 = smp.host_time_s;
    t0 = std::min(t0, smp.host_time_s);
    t1 = std::max(t1, smp.host_time_s);
    ++used;
  }
  std::string missing;
  for (auto& st : stats) {
    if (st.count < opt.min_samples)
      missing += (missing.empty() ? "" : ", ") + st.binding->name + " (sensor " + std::to_string(st.binding->sensor) +
                 ", " + std::to_string(st.count) + " samples)";
  }
  if (!missing.empty())
    return fail(Errc::not_found, "calibration refused: no data from " + missing + "; check that every sensor is connected");
  for (auto& st : stats) {
    st.mean_pos = glm::vec3(st.sum / static_cast<double>(st.count));
    st.mean_rot = glm::normalize(glm::quat(glm::normalize(st.qsum)));
  }
  for (const auto& smp : capture) {
    if (!(smp.flags & devices::kSampleValid) || !finite(smp)) continue;
    auto it = slot.find(smp.sensor);
    if (it == slot.end()) continue;
    SensorStats& st = stats[it->second];
    st.max_dist_m = std::max(st.max_dist_m, glm::length(smp.position_m - st.mean_pos));
    st.max_angle_deg = std::max(st.max_angle_deg, angle_deg(glm::normalize(smp.orientation), st.mean_rot));
  }
  Calibration cal;
  std::string moved;
  for (const auto& st : stats) {
    cal.max_motion_mm = std::max(cal.max_motion_mm, 1000.0f * st.max_dist_m);
    cal.max_motion_deg = std::max(cal.max_motion_deg, st.max_angle_deg);
    if (st.max_dist_m > opt.max_motion_m || st.max_angle_deg > opt.max_motion_deg)
      moved += (moved.empty() ? "" : ", ") + st.binding->name + " moved " + fmt(100.0f * st.max_dist_m) + " cm / " +
               fmt(st.max_angle_deg) + "°";
  }
  if (!moved.empty())
    return fail(Errc::out_of_range, "calibration refused: the wearer moved (" + moved + "; limits " +
                                        fmt(100.0f * opt.max_motion_m) + " cm / " + fmt(opt.max_motion_deg) +
                                        "°); stand still and try again");

  // Heading from left–right pairs (left minus right points to the wearer's left, +X at 0).
  glm::vec3 left(0.0f);
  for (const auto& a : stats) {
    const std::string& seg = a.binding->segment;
    if (seg.rfind("l_", 0) != 0) continue;
    for (const auto& b : stats)
      if (b.binding->segment == "r_" + seg.substr(2)) left += a.mean_pos - b.mean_pos;
  }
  float heading_rad = 0;
  if (glm::length(glm::vec2(left.x, left.z)) > 0.05f) heading_rad = std::atan2(-left.z, left.x);
  const glm::quat heading = glm::angleAxis(heading_rad, glm::vec3(0, 1, 0));

  // Passes until the marks agree with the posture fitted to them: each places the sensors with
  // the segment rotations of the last (the heading alone on the first). Two were not enough —
  // a hand's mark placed with the first pass's level hand sat millimetres from where the fitted,
  // drooping arm put it, and the sensor's offset carried that difference.
  std::map<std::string, glm::quat> segment_rot;
  Fit fit = fit_body(base, stats, heading, segment_rot, opt);
  for (int pass = 1; pass < kMaxFitPasses; ++pass) {
    const Skeleton s = *Skeleton::build(fit.desc);
    const auto w = pose_world(s, fit.pose);
    float turned_deg = 0;
    for (int j = 0; j < s.joint_count(); ++j) {
      const auto it = segment_rot.try_emplace(s.joint_name(j), heading).first;
      turned_deg = std::max(turned_deg, angle_deg(it->second, w[j].rotation));
      it->second = w[j].rotation;
    }
    if (pass > 1 && turned_deg < 0.05f) break;
    fit = fit_body(base, stats, heading, segment_rot, opt);
  }

  const Skeleton s = *Skeleton::build(fit.desc);
  const auto w = pose_world(s, fit.pose);
  cal.skeleton = fit.desc;
  cal.pose = opt.pose;
  cal.height_m = fit.height_m;
  cal.floor_y_m = fit.floor_y_m;
  cal.standing_root_y_m = fit.pose.root_position_m.y;
  cal.heading_deg = glm::degrees(heading_rad);
  cal.samples = used;
  cal.duration_s = t1 - t0;
  for (const auto& st : stats) {
    const int j = s.find_joint(st.binding->segment);
    SensorCalibration sc;
    sc.sensor = st.binding->sensor;
    sc.name = st.binding->name;
    sc.segment = st.binding->segment;
    sc.segment_from_sensor = w[j].inverse() * RigidTransform{st.mean_rot, st.mean_pos};
    cal.sensors.push_back(sc);
  }
  return cal;
}

Result<SolverModel> make_solver_model(const Calibration& cal, SolverOptions options) {
  auto s = Skeleton::build(cal.skeleton);
  if (!s) return tl::unexpected(s.error());
  if (!std::isfinite(options.standing_root_y_m) && cal.standing_root_y_m != 0)
    options.standing_root_y_m = cal.standing_root_y_m;
  std::vector<SensorMount> mounts;
  for (const auto& sc : cal.sensors) mounts.push_back(SensorMount{sc.sensor, sc.segment, sc.segment_from_sensor});
  return SolverModel::create(std::move(*s), std::move(mounts), options);
}

// --- JSON -------------------------------------------------------------------------------------

namespace {

using nlohmann::json;

json vec(const glm::vec3& v) { return json::array({v.x, v.y, v.z}); }

// Numbers as floats without undefined conversions: a value beyond float's range is refused.
bool read_float(const json& j, float& out) {
  if (!j.is_number()) return false;
  const double v = j.get<double>();
  if (!std::isfinite(v) || std::abs(v) > 3.0e38) return false;
  out = static_cast<float>(v);
  return true;
}

// A member of the expected type, or the default: never an exception on a wrong type.
std::string string_or(const json& j, const char* key, const std::string& fallback) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : fallback;
}

bool read_vec(const json& j, glm::vec3& out) {
  if (!j.is_array() || j.size() != 3) return false;
  for (int i = 0; i < 3; ++i) {
    if (!j[i].is_number()) return false;
    if (!read_float(j[i], out[i])) return false;
  }
  return std::isfinite(out.x) && std::isfinite(out.y) && std::isfinite(out.z);
}

}  // namespace

std::string calibration_to_json(const Calibration& cal) {
  json j;
  j["format"] = "mimic-calibration";
  j["version"] = 1;
  j["pose"] = calibration_pose_name(cal.pose);
  j["height_m"] = cal.height_m;
  j["heading_deg"] = cal.heading_deg;
  j["floor_y_m"] = cal.floor_y_m;
  j["standing_root_y_m"] = cal.standing_root_y_m;
  j["capture"] = {{"samples", cal.samples}, {"duration_s", cal.duration_s},
                  {"max_motion_mm", cal.max_motion_mm}, {"max_motion_deg", cal.max_motion_deg}};
  json sensors = json::array();
  for (const auto& sc : cal.sensors) {
    const glm::quat& q = sc.segment_from_sensor.rotation;
    sensors.push_back({{"sensor", sc.sensor}, {"name", sc.name}, {"segment", sc.segment},
                       {"translation_m", vec(sc.segment_from_sensor.translation)},
                       {"rotation_wxyz", json::array({q.w, q.x, q.y, q.z})}});
  }
  j["sensors"] = sensors;
  json joints = json::array();
  for (const auto& jd : cal.skeleton.joints) {
    json dofs = json::array();
    for (const auto& f : jd.dofs)
      dofs.push_back({{"name", f.name}, {"axis", vec(f.axis)}, {"min_deg", glm::degrees(f.min_rad)},
                      {"max_deg", glm::degrees(f.max_rad)}, {"rest_deg", glm::degrees(f.rest_rad)}});
    joints.push_back({{"name", jd.name}, {"parent", jd.parent}, {"offset_m", vec(jd.offset_m)},
                      {"tip_m", vec(jd.tip_m)}, {"dofs", dofs}});
  }
  j["skeleton"] = {{"joints", joints}};
  return j.dump(1) + "\n";
}

Result<Calibration> calibration_from_json(std::string_view text) {
  const json j = json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded()) return fail(Errc::parse_error, "calibration: not valid JSON");
  auto bad = [](const std::string& what) { return fail(Errc::parse_error, "calibration: " + what); };
  if (!j.is_object() || string_or(j, "format", "") != "mimic-calibration") return bad("not a mimic-calibration file (\"format\")");
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<int64_t>() != 1)
    return bad("unsupported version (expected 1)");
  Calibration cal;
  if (j.contains("pose") && !j["pose"].is_string()) return bad("\"pose\" must be tpose or npose");
  auto pose = parse_calibration_pose(string_or(j, "pose", "tpose"));
  if (!pose) return bad("\"pose\" must be tpose or npose");
  cal.pose = *pose;
  if (j.contains("height_m")) read_float(j["height_m"], cal.height_m);
  if (j.contains("heading_deg")) read_float(j["heading_deg"], cal.heading_deg);
  if (j.contains("floor_y_m")) read_float(j["floor_y_m"], cal.floor_y_m);
  if (j.contains("standing_root_y_m")) read_float(j["standing_root_y_m"], cal.standing_root_y_m);
  if (j.contains("capture") && j["capture"].is_object()) {
    const json& c = j["capture"];
    if (c.contains("samples") && c["samples"].is_number_integer()) {
      const int64_t n = c["samples"].get<int64_t>();
      cal.samples = static_cast<int>(std::clamp<int64_t>(n, 0, INT32_MAX));
    }
    if (c.contains("duration_s") && c["duration_s"].is_number()) cal.duration_s = c["duration_s"].get<double>();
    if (c.contains("max_motion_mm")) read_float(c["max_motion_mm"], cal.max_motion_mm);
    if (c.contains("max_motion_deg")) read_float(c["max_motion_deg"], cal.max_motion_deg);
  }
  if (!j.contains("skeleton") || !j["skeleton"].is_object() || !j["skeleton"].contains("joints") ||
      !j["skeleton"]["joints"].is_array())
    return bad("missing \"skeleton\".\"joints\"");
  int index = 0;
  for (const json& jj : j["skeleton"]["joints"]) {
    const std::string where = "skeleton joint " + std::to_string(index++);
    if (!jj.is_object() || !jj.contains("name") || !jj["name"].is_string()) return bad(where + ": missing \"name\"");
    rig::JointDesc jd;
    jd.name = jj["name"].get<std::string>();
    if (jj.contains("parent") && jj["parent"].is_string()) jd.parent = jj["parent"].get<std::string>();
    if (!jj.contains("offset_m") || !read_vec(jj["offset_m"], jd.offset_m)) return bad(where + " (" + jd.name + "): bad \"offset_m\"");
    if (!jj.contains("tip_m") || !read_vec(jj["tip_m"], jd.tip_m)) return bad(where + " (" + jd.name + "): bad \"tip_m\"");
    if (jj.contains("dofs")) {
      if (!jj["dofs"].is_array()) return bad(where + " (" + jd.name + "): \"dofs\" is not an array");
      for (const json& fj : jj["dofs"]) {
        rig::DofDesc f;
        if (!fj.is_object() || !fj.contains("name") || !fj["name"].is_string() || !fj.contains("axis") ||
            !read_vec(fj["axis"], f.axis) || !fj.contains("min_deg") || !fj["min_deg"].is_number() ||
            !fj.contains("max_deg") || !fj["max_deg"].is_number())
          return bad(where + " (" + jd.name + "): a DOF needs name, axis, min_deg, max_deg");
        f.name = fj["name"].get<std::string>();
        float min_deg = 0, max_deg = 0, rest_deg = 0;
        if (!read_float(fj["min_deg"], min_deg) || !read_float(fj["max_deg"], max_deg) ||
            (fj.contains("rest_deg") && !read_float(fj["rest_deg"], rest_deg)))
          return bad(where + " (" + jd.name + "): DOF '" + f.name + "' has a limit that is not a finite number");
        f.min_rad = glm::radians(min_deg);
        f.max_rad = glm::radians(max_deg);
        f.rest_rad = glm::radians(rest_deg);
        jd.dofs.push_back(f);
      }
    }
    cal.skeleton.joints.push_back(std::move(jd));
  }
  if (auto s = Skeleton::build(cal.skeleton); !s) return bad("skeleton: " + s.error().message);
  if (!j.contains("sensors") || !j["sensors"].is_array()) return bad("missing \"sensors\"");
  index = 0;
  for (const json& sj : j["sensors"]) {
    const std::string where = "sensor entry " + std::to_string(index++);
    SensorCalibration sc;
    if (!sj.is_object() || !sj.contains("sensor") || !sj["sensor"].is_number_unsigned() || sj["sensor"].get<unsigned>() > 65535)
      return bad(where + ": bad \"sensor\" id");
    sc.sensor = static_cast<uint16_t>(sj["sensor"].get<unsigned>());
    if (!sj.contains("segment") || !sj["segment"].is_string()) return bad(where + ": missing \"segment\"");
    sc.segment = sj["segment"].get<std::string>();
    sc.name = string_or(sj, "name", sc.segment);
    if (!sj.contains("translation_m") || !read_vec(sj["translation_m"], sc.segment_from_sensor.translation))
      return bad(where + ": bad \"translation_m\"");
    const json& q = sj.contains("rotation_wxyz") ? sj["rotation_wxyz"] : json();
    if (!q.is_array() || q.size() != 4 || !q[0].is_number() || !q[1].is_number() || !q[2].is_number() || !q[3].is_number())
      return bad(where + ": bad \"rotation_wxyz\"");
    float qw = 0, qx = 0, qy = 0, qz = 0;
    if (!read_float(q[0], qw) || !read_float(q[1], qx) || !read_float(q[2], qy) || !read_float(q[3], qz))
      return bad(where + ": \"rotation_wxyz\" is not four finite numbers");
    glm::quat r(qw, qx, qy, qz);
    if (!(glm::dot(r, r) > 0.5f && glm::dot(r, r) < 2.0f)) return bad(where + ": \"rotation_wxyz\" is not a unit quaternion");
    sc.segment_from_sensor.rotation = glm::normalize(r);
    cal.sensors.push_back(sc);
  }
  return cal;
}

Status save_calibration(const std::string& path, const Calibration& cal) {
  return write_file_atomic(path, calibration_to_json(cal));
}

Result<Calibration> load_calibration(const std::string& path) {
  auto text = read_file(path);
  if (!text) return tl::unexpected(text.error());
  auto cal = calibration_from_json(*text);
  if (!cal) return fail(cal.error().code, path + ": " + cal.error().message);
  return cal;
}

}  // namespace mimic::solver
