// How well a skinning method keeps the body's shape at its joints: the joint-zone volume
// (joint_zone.h) while a joint sweeps through its range, as a % change from the relaxed pose,
// the smallest of the zone's cross-sections as a fraction of the same section at rest, and how
// far the skin stands off the bones beyond its rest distance (the outer corner's point).
// Measured for the full contour method (ImplicitSkin, ray cast every frame, realtime resolution),
// the realtime contour method (RealtimeSkin, with its muscle terms) and the three baselines
// (LBS, DQS, CoR) bound to the same rest mesh with the contour-derived weights — what
// `mimic inspect` prints.
#pragma once

#include <string>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

struct JointSweep {
  std::string name;                // e.g. "elbow_flexion"
  std::string dof;                 // the swept DOF, e.g. "l_elbow_flexion"
  std::string joint;               // the zone's joint, e.g. "l_elbow"
  std::vector<std::string> parts;  // skin pieces the zone is measured on (closed across it)
  float half_length_m = 0.08f;     // JointZone::half_length_m
  std::vector<float> angles_deg;   // the first is the relaxed value the others compare with
};

// Left elbow flexion 0→150°, left knee flexion 0→150° (every 10°), left forearm twist
// 0, ±15 … ±90°. Half-lengths: 35% of the shorter of the joint's two links.
std::vector<JointSweep> standard_joint_sweeps(const BodyModel& model);

struct SweepSample {
  float angle_deg = 0;
  double volume_change_pct = 0;     // 100 (V / V_relaxed − 1)
  double min_section_fraction = 1;  // min over the five stations of A / A_relaxed (may exceed 1)
  // How far the skin stands off the bones beyond its rest distance: over the zone's vertices, the
  // largest gain of the distance to the two links (segments) against the relaxed pose, mm. A
  // mitred joint's outer corner (a beak, a needle at full flexion) shows here; flesh wrapping
  // round the joint keeps it near 0.
  double stand_off_mm = 0;
};

struct MethodSweep {
  std::string method;                // "full", "realtime", "lbs", "dqs", "cor"
  std::vector<SweepSample> samples;  // one per JointSweep::angles_deg
};

struct SweepResult {
  JointSweep sweep;
  std::vector<MethodSweep> methods;
};

struct InspectOptions {
  int lod = 0;          // skin_lod.h
  bool muscles = true;  // the realtime method's muscle terms
};

// Runs every sweep for every method (zero posture otherwise). Allocates; a few hundred
// milliseconds for the default body. Fails when the body cannot be skinned or a sweep names an
// unknown DOF or joint.
Result<std::vector<SweepResult>> inspect_joint_zones(const BodyModel& model, const std::vector<JointSweep>& sweeps,
                                                     const InspectOptions& options = {});

}  // namespace mimic::avatar
