#include "mimic/solver/calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <glm/gtx/norm.hpp>

#include "calibration_fit.h"
#include "sample_check.h"

namespace mimic::solver {

using detail::angle_deg;
using detail::Fit;
using detail::pose_world;
using detail::SensorStats;
using rig::RigidTransform;
using rig::Skeleton;
using rig::SkeletonDesc;

namespace {

constexpr int kMaxFitPasses = 4;  // fits of the body to the stand-still, at most

std::string fmt(float v, const char* f = "%.1f") {
  char b[32];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

bool usable(const devices::SensorSample& s) { return (s.flags & devices::kSampleValid) && detail::finite_sample(s); }

// Per-sensor mean pose and spread over the capture; the time span and sample count in `cal`.
std::vector<SensorStats> measure_capture(const SensorLayout& layout, std::span<const devices::SensorSample> capture,
                                         Calibration& cal) {
  std::vector<SensorStats> stats(layout.bindings.size());
  std::map<uint16_t, size_t> slot;
  for (size_t i = 0; i < layout.bindings.size(); ++i) {
    stats[i].binding = &layout.bindings[i];
    slot[layout.bindings[i].sensor] = i;
  }
  double t0 = 0, t1 = 0;
  int used = 0;
  for (const auto& smp : capture) {
    if (!usable(smp)) continue;
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
  for (auto& st : stats) {
    if (st.count == 0) continue;
    st.mean_pos = glm::vec3(st.sum / static_cast<double>(st.count));
    st.mean_rot = glm::normalize(glm::quat(glm::normalize(st.qsum)));
  }
  for (const auto& smp : capture) {
    if (!usable(smp)) continue;
    auto it = slot.find(smp.sensor);
    if (it == slot.end()) continue;
    SensorStats& st = stats[it->second];
    st.max_dist_m = std::max(st.max_dist_m, glm::length(smp.position_m - st.mean_pos));
    st.max_angle_deg = std::max(st.max_angle_deg, angle_deg(glm::normalize(smp.orientation), st.mean_rot));
  }
  cal.samples = used;
  cal.duration_s = t1 - t0;
  for (const auto& st : stats) {
    cal.max_motion_mm = std::max(cal.max_motion_mm, 1000.0f * st.max_dist_m);
    cal.max_motion_deg = std::max(cal.max_motion_deg, st.max_angle_deg);
  }
  return stats;
}

// The capture refused, with the reason: a sensor without enough samples, or one that moved.
Status check_capture(const std::vector<SensorStats>& stats, const CalibrationOptions& opt) {
  std::string missing;
  for (const auto& st : stats) {
    if (st.count < opt.min_samples)
      missing += (missing.empty() ? "" : ", ") + st.binding->name + " (sensor " + std::to_string(st.binding->sensor) +
                 ", " + std::to_string(st.count) + " samples)";
  }
  if (!missing.empty())
    return fail(Errc::not_found,
                "calibration refused: no data from " + missing + "; check that every sensor is connected");
  std::string moved;
  for (const auto& st : stats) {
    if (st.max_dist_m > opt.max_motion_m || st.max_angle_deg > opt.max_motion_deg)
      moved += (moved.empty() ? "" : ", ") + st.binding->name + " moved " + fmt(100.0f * st.max_dist_m) + " cm / " +
               fmt(st.max_angle_deg) + "°";
  }
  if (!moved.empty())
    return fail(Errc::out_of_range, "calibration refused: the wearer moved (" + moved + "; limits " +
                                        fmt(100.0f * opt.max_motion_m) + " cm / " + fmt(opt.max_motion_deg) +
                                        "°); stand still and try again");
  return {};
}

// Heading from left–right pairs (left minus right points to the wearer's left, +X at 0); 0 when
// no pair shows it.
float heading_rad_of(const std::vector<SensorStats>& stats) {
  glm::vec3 left(0.0f);
  for (const auto& a : stats) {
    const std::string& seg = a.binding->segment;
    if (seg.rfind("l_", 0) != 0) continue;
    for (const auto& b : stats)
      if (b.binding->segment == "r_" + seg.substr(2)) left += a.mean_pos - b.mean_pos;
  }
  if (glm::length(glm::vec2(left.x, left.z)) > 0.05f) return std::atan2(-left.z, left.x);
  return 0.0f;
}

// Passes until the marks agree with the posture fitted to them: each places the sensors with
// the segment rotations of the last (the heading alone on the first). Two were not enough — a
// hand's mark placed with the first pass's level hand sat millimetres from where the fitted,
// drooping arm put it, and the sensor's offset carried that difference.
Fit fit_passes(const SkeletonDesc& base, const std::vector<SensorStats>& stats, const glm::quat& heading,
               const CalibrationOptions& opt) {
  detail::SegmentRotations segment_rot;
  Fit fit = detail::fit_body(base, stats, heading, segment_rot, opt);
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
    fit = detail::fit_body(base, stats, heading, segment_rot, opt);
  }
  return fit;
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
    if (rig::JointDesc* hp = find(sd + "hip"); hp)
      hp->offset_m = glm::vec3(x * 0.112f * leg, -0.120f * leg, 0.045f * leg);
  }
  return d;
}

const char* calibration_pose_name(CalibrationPose pose) { return pose == CalibrationPose::n_pose ? "npose" : "tpose"; }

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

  Calibration cal;
  const std::vector<SensorStats> stats = measure_capture(layout, capture, cal);
  if (Status ok = check_capture(stats, opt); !ok) return tl::unexpected(ok.error());
  const float heading_rad = heading_rad_of(stats);
  const glm::quat heading = glm::angleAxis(heading_rad, glm::vec3(0, 1, 0));
  const Fit fit = fit_passes(base, stats, heading, opt);

  const Skeleton s = *Skeleton::build(fit.desc);
  const auto w = pose_world(s, fit.pose);
  cal.skeleton = fit.desc;
  cal.pose = opt.pose;
  cal.height_m = fit.height_m;
  cal.floor_y_m = fit.floor_y_m;
  cal.standing_root_y_m = fit.pose.root_position_m.y;
  cal.heading_deg = glm::degrees(heading_rad);
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

}  // namespace mimic::solver
