// The postures the junction-fold tests bend both skin methods through, and the folds of one
// posture inside the pieces of one part (tests/exact: CGAL's exact test).
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <string_view>
#include <vector>

#include "mimic/avatar/self_intersection.h"
#include "mimic/rig/skeleton.h"

namespace mimic::test {

// Folds inside the pieces whose name holds `part` ("upper_arm": both upper arms; "": all).
inline size_t folds_in(const avatar::SelfIntersectionChecker& checker, const avatar::Mesh& m, std::string_view part) {
  size_t n = 0;
  for (const avatar::PartPairCount& c : checker.check(m.positions).by_parts)
    if (c.a == c.b && c.a.find(part) != std::string::npos) n += c.pairs;
  return n;
}

// Zero postures with a few of one side's DOFs set (degrees), the sides `l_` and `r_` in turn.
struct SidePosture {
  std::vector<std::pair<std::string, float>> dofs_deg;  // names without the side's prefix
};
inline std::vector<rig::Pose> both_sides(const rig::Skeleton& sk, const std::vector<SidePosture>& postures) {
  std::vector<rig::Pose> out;
  for (const char* side : {"l_", "r_"})
    for (const SidePosture& s : postures) {
      rig::Pose p = sk.zero_pose();
      for (const auto& [name, deg] : s.dofs_deg) {
        const int d = sk.find_dof(side + name);
        EXPECT_GE(d, 0) << side << name;
        if (d >= 0) p.dof_rad[d] = glm::radians(deg);
      }
      out.push_back(std::move(p));
    }
  return out;
}

// The upper arm twisted far about its own axis, raised, hanging and swung forward: 64 postures.
inline std::vector<rig::Pose> twisted_arm_postures(const rig::Skeleton& sk) {
  std::vector<SidePosture> s;
  for (float abduction_deg : {-60.0f, 0.0f, 60.0f, 100.0f})
    for (float flexion_deg : {0.0f, 60.0f})
      for (float twist_deg : {-110.0f, -60.0f, 60.0f, 110.0f})
        s.push_back({{{"shoulder_abduction", abduction_deg},
                      {"shoulder_flexion", flexion_deg},
                      {"shoulder_twist", twist_deg}}});
  return both_sides(sk, s);
}

// The thigh raised forward, from 30 to 130 degrees, and out: 30 postures.
inline std::vector<rig::Pose> raised_thigh_postures(const rig::Skeleton& sk) {
  std::vector<SidePosture> s;
  for (float flexion_deg : {30.0f, 60.0f, 90.0f, 110.0f, 130.0f})
    for (float abduction_deg : {-15.0f, 0.0f, 30.0f})
      s.push_back({{{"hip_flexion", flexion_deg}, {"hip_abduction", abduction_deg}}});
  return both_sides(sk, s);
}

}  // namespace mimic::test
