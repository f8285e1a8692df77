// The girths the fit holds (body_fit.h): measured both sides, and their part of the score.
#include <cmath>
#include <numbers>

#include "body_fit_internal.h"

namespace mimic::avatar::fit_detail {

namespace {

// x → 2c − x about the plane x = c: the body's right side becomes a left one.
glm::vec3 mirror(glm::vec3 p, float c) { return {2.0f * c - p.x, p.y, p.z}; }

LimbLandmarks mirror(const LimbLandmarks& l, float c) {
  return {mirror(l.hip_m, c),      mirror(l.knee_m, c),  mirror(l.ankle_m, c),
          mirror(l.shoulder_m, c), mirror(l.elbow_m, c), mirror(l.wrist_m, c)};
}

GirthTape mirror(GirthTape t, float c) {
  t.point = mirror(t.point, c);
  t.normal.x = -t.normal.x;
  for (auto* points : {&t.include, &t.exclude})
    for (glm::vec3& p : *points) p = mirror(p, c);
  return t;
}

}  // namespace

Girths measure_girths(const Mesh& mesh, const BodyLandmarks& lm) {
  Girths out;
  GirthTapes tapes;
  const BodyMeasurements left = measure_body(mesh, lm, &tapes);
  out.value = {left.chest_girth_m, left.waist_girth_m, left.hip_girth_m,
               left.thigh_girth_m, left.calf_girth_m,  left.upper_arm_girth_m};
  out.tape = {tapes.chest, tapes.waist, tapes.hips, tapes.thigh, tapes.calf, tapes.upper_arm};
  // The right limbs: the same measurement of the mirror image (its winding reversed does not
  // matter to a cross-section), the tapes mirrored back.
  const float c = lm.pelvis_m.x;
  Mesh mirrored;
  mirrored.positions.reserve(mesh.positions.size());
  for (const glm::vec3& p : mesh.positions) mirrored.positions.push_back(mirror(p, c));
  mirrored.indices = mesh.indices;
  BodyLandmarks mlm = lm;
  mlm.pelvis_m = mirror(lm.pelvis_m, c);
  for (glm::vec3& p : mlm.spine_m) p = mirror(p, c);
  mlm.neck_m = mirror(lm.neck_m, c), mlm.head_m = mirror(lm.head_m, c), mlm.head_top_m = mirror(lm.head_top_m, c);
  mlm.left = mirror(lm.right, c), mlm.right = mirror(lm.left, c);
  const BodyMeasurements right = measure_body(mirrored, mlm, &tapes);
  out.value[6] = right.thigh_girth_m, out.value[7] = right.calf_girth_m, out.value[8] = right.upper_arm_girth_m;
  int k = 6;
  for (const auto* t : {&tapes.thigh, &tapes.calf, &tapes.upper_arm}) {
    if (*t) out.tape[size_t(k)] = mirror(**t, c);
    ++k;
  }
  return out;
}

float girth_excess_m(float girth_m, float reference_m, float band) {
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  const float r = (girth_m - reference_m) / two_pi, allowed = band * reference_m / two_pi;
  return std::abs(r) <= allowed ? 0.0f : std::copysign(std::abs(r) - allowed, r);
}

double girth_penalty_m(const Girths& ours, const Girths& reference, const FitOptions& options, float* largest) {
  double sum = 0;
  float worst = 0;
  for (int g = 0; g < kGirths; ++g) {
    const auto &a = ours.value[size_t(g)], &b = reference.value[size_t(g)];
    if (!b) continue;
    // A girth the body lost (no loop round its axis) counts as far off as the reference's radius.
    const float excess = a ? girth_excess_m(*a, *b, options.girth_band) : *b / (2.0f * std::numbers::pi_v<float>);
    sum += std::abs(excess);
    if (a) worst = std::max(worst, std::abs(*a / *b - 1.0f));
  }
  if (largest) *largest = worst;
  return sum * options.girth_weight;
}

}  // namespace mimic::avatar::fit_detail
