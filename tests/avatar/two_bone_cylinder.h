// A closed cylinder (radius 5 cm) around a two-bone chain along +X — upper link 0..0.3 m,
// lower link 0.3..0.6 m, the elbow at x = 0.3 with flexion about Z and twist about X — for the
// baseline skinning and joint-zone tests.
#pragma once

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"

namespace mimic::avatar::testing {

inline rig::Skeleton two_bone_skeleton() {
  rig::SkeletonDesc d;
  const float pi = std::numbers::pi_v<float>;
  d.joints.push_back({"upper", "", {0, 0, 0}, {0.3f, 0, 0}, {}});
  d.joints.push_back({"lower",
                      "upper",
                      {0.3f, 0, 0},
                      {0.3f, 0, 0},
                      {rig::DofDesc{"flexion", {0, 0, 1}, -pi, pi, 0}, rig::DofDesc{"twist", {1, 0, 0}, -pi, pi, 0}}});
  auto s = rig::Skeleton::build(d);
  EXPECT_TRUE(s) << s.error().what();
  return std::move(*s);
}

// `rings` rings of `around` points from x = 0 to 0.6, closed by a fan at each end around a
// centre vertex; outward normals; counter-clockwise seen from outside.
inline Mesh cylinder_mesh(int rings = 61, int around = 48, float radius_m = 0.05f, float length_m = 0.6f) {
  Mesh m;
  const float two_pi = 2 * std::numbers::pi_v<float>;
  for (int r = 0; r < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const float phi = two_pi * float(a) / float(around);
      const float x = length_m * float(r) / float(rings - 1);
      m.positions.push_back({x, radius_m * std::cos(phi), radius_m * std::sin(phi)});
      m.normals.push_back({0, std::cos(phi), std::sin(phi)});
    }
  auto at = [&](int r, int a) { return uint32_t(r * around + (a % around)); };
  for (int r = 0; r + 1 < rings; ++r)
    for (int a = 0; a < around; ++a) {
      // Around +X, phi grows from +Y to +Z: (r,a) → (r,a+1) → (r+1,a+1) winds outward.
      m.indices.insert(m.indices.end(), {at(r, a), at(r, a + 1), at(r + 1, a + 1)});
      m.indices.insert(m.indices.end(), {at(r, a), at(r + 1, a + 1), at(r + 1, a)});
    }
  const uint32_t c0 = uint32_t(m.positions.size());
  m.positions.push_back({0, 0, 0});
  m.normals.push_back({-1, 0, 0});
  const uint32_t c1 = uint32_t(m.positions.size());
  m.positions.push_back({length_m, 0, 0});
  m.normals.push_back({1, 0, 0});
  for (int a = 0; a < around; ++a) {
    m.indices.insert(m.indices.end(), {c0, at(0, a + 1), at(0, a)});
    m.indices.insert(m.indices.end(), {c1, at(rings - 1, a), at(rings - 1, a + 1)});
  }
  m.parts.push_back({"cylinder", 0, uint32_t(m.indices.size() / 3)});
  return m;
}

}  // namespace mimic::avatar::testing
