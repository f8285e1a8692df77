#include <gtest/gtest.h>

#include <cmath>

#include "mimic/avatar/bspline.h"

namespace mimic::avatar::bspline_test {
namespace {

TEST(Bspline, PeriodicWeightsArePartitionOfUnity) {
  for (int controls : {3, 4, 7, 36}) {
    for (int per_span : {1, 2, 3, 5}) {
      const auto taps = periodic_cubic_taps(controls, per_span);
      ASSERT_EQ(taps.size(), static_cast<size_t>(controls * per_span));
      for (const auto& t : taps) {
        EXPECT_NEAR(t.weight[0] + t.weight[1] + t.weight[2] + t.weight[3], 1.0f, 1e-6f);
        for (float w : t.weight) EXPECT_GE(w, 0.0f);
        for (uint32_t i : t.index) EXPECT_LT(i, static_cast<uint32_t>(controls));
      }
    }
  }
}

TEST(Bspline, ClampedWeightsArePartitionOfUnityAndInterpolateTheEnds) {
  for (int controls : {2, 3, 4, 5, 12}) {
    for (int samples : {2, 5, 17}) {
      const auto taps = clamped_cubic_taps(controls, samples);
      for (const auto& t : taps) {
        EXPECT_NEAR(t.weight[0] + t.weight[1] + t.weight[2] + t.weight[3], 1.0f, 1e-5f);
        for (float w : t.weight) EXPECT_GE(w, -1e-6f);
        for (uint32_t i : t.index) EXPECT_LT(i, static_cast<uint32_t>(controls));
      }
      std::vector<glm::vec3> pts;
      for (int i = 0; i < controls; ++i) pts.push_back({float(i), float(i * i), 1.0f});
      EXPECT_EQ(apply_tap(taps.front(), pts), pts.front());
      EXPECT_EQ(apply_tap(taps.back(), pts), pts.back());
    }
  }
}

TEST(Bspline, ClampedReproducesStraightLines) {
  // Linear precision: control points evenly spaced on a line give points on that line.
  std::vector<glm::vec3> pts;
  for (int i = 0; i < 9; ++i) pts.push_back(glm::vec3(1, 2, 3) + float(i) * glm::vec3(0.5f, -1, 2));
  for (const auto& t : clamped_cubic_taps(9, 33)) {
    const glm::vec3 p = apply_tap(t, pts) - glm::vec3(1, 2, 3);
    const glm::vec3 dir = glm::normalize(glm::vec3(0.5f, -1, 2));
    EXPECT_NEAR(glm::length(p - glm::dot(p, dir) * dir), 0.0f, 1e-4f);
  }
}

TEST(Bspline, PeriodicSmoothsACircleInward) {
  // Samples of a closed cubic B-spline over a regular polygon stay inside it, close to the circle.
  const int n = 24;
  std::vector<glm::vec3> pts;
  for (int i = 0; i < n; ++i) {
    const float a = 6.2831853f * float(i) / float(n);
    pts.push_back({std::cos(a), std::sin(a), 0});
  }
  for (const auto& t : periodic_cubic_taps(n, 4)) {
    const float r = glm::length(apply_tap(t, pts));
    EXPECT_LE(r, 1.0f + 1e-6f);
    EXPECT_GT(r, 0.985f);
  }
}

}  // namespace
}  // namespace mimic::avatar::bspline_test
