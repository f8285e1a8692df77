// Uniform cubic B-spline sampling used to smooth contour grids: closed (periodic) around a
// contour, open (clamped, end-interpolating) along a limb. A sampler is a fixed table of
// (first control point, 4 weights) per output sample, so evaluation is a gather and 4 FMAs.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace mimic::avatar {

struct BsplineTap {
  std::array<uint32_t, 4> index{};  // control point indices (periodic wrap already applied)
  std::array<float, 4> weight{};    // sum to 1
};

// `controls` points on a closed curve, `per_span` samples per span: controls × per_span
// samples, sample i·per_span at control point i's knot.
std::vector<BsplineTap> periodic_cubic_taps(int controls, int per_span);

// `controls` points on an open curve clamped at both ends (degree min(3, controls − 1)),
// `samples` ≥ 2 samples evenly spaced in the parameter; the first and last samples are the
// first and last control points exactly.
std::vector<BsplineTap> clamped_cubic_taps(int controls, int samples);

inline glm::vec3 apply_tap(const BsplineTap& tap, std::span<const glm::vec3> points) {
  return tap.weight[0] * points[tap.index[0]] + tap.weight[1] * points[tap.index[1]] +
         tap.weight[2] * points[tap.index[2]] + tap.weight[3] * points[tap.index[3]];
}

}  // namespace mimic::avatar
