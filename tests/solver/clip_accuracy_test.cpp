// The solver on shared CMU clips with simulated sensors (1 mm / 0.5° noise, straps askew):
// loose bounds that catch regressions; the measured figures are in bench/solver and
// `mimic eval-solver`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string_view>

#include "clip_eval.h"
#include "mimic/rig/bvh.h"
#include "test_data.h"

namespace mimic::solver::clip_accuracy_test {
namespace {

const rig::RetargetedClip* load(const std::string& id) {
  static std::map<std::string, std::unique_ptr<rig::RetargetedClip>> cache;
  if (auto it = cache.find(id); it != cache.end()) return it->second.get();
  auto bvh = rig::load_bvh(test::clip_path(id));
  if (!bvh) return nullptr;
  auto r = rig::retarget_bvh(*bvh);
  if (!r) return nullptr;
  return (cache[id] = std::make_unique<rig::RetargetedClip>(std::move(*r))).get();
}

struct Bound {
  const char* layout;
  double mpjpe_cm, end_effector_mm;
};

TEST(ClipAccuracy, SimulatedSensorsOnSharedClipsStayWithinBounds) {
  if (!std::filesystem::exists(test::clip_path("07_01"))) GTEST_SKIP() << "shared data not found";
  // Three sensors: the stepping feet are out of phase with the truth's part of the time, which
  // costs the ankles more than feet hanging under the hips did (end effectors 168 mm on 07_01's
  // first two seconds, against 96 mm).
  const Bound bounds[] = {{"3", 11.0, 200.0}, {"6", 3.0, 8.0}, {"11", 1.6, 8.0}, {"all", 1.0, 8.0}};
  for (const char* id : {"07_01", "13_26"}) {
    const auto* clip = load(id);
    ASSERT_NE(clip, nullptr) << id;
    for (const auto& b : bounds) {
      testing::ClipEvalConfig cfg;
      cfg.layout = b.layout;
      cfg.max_frames = 240;  // two seconds keep the test quick
      const auto r = testing::evaluate_clip(*clip, cfg);
      ASSERT_TRUE(r.error.empty()) << r.error;
      const auto& p = r.report;
      EXPECT_EQ(p.frames, 240);
      EXPECT_TRUE(std::isfinite(p.mpjpe_cm) && std::isfinite(p.mpjre_deg));
      std::printf("  %s, %s sensors: MPJPE %.2f cm, end effectors %.1f mm, jitter %.2f mm (truth %.2f)\n", id, b.layout,
                  p.mpjpe_cm, p.end_effector_mm, p.jitter_mm, p.jitter_truth_mm);
      EXPECT_LT(p.mpjpe_cm, b.mpjpe_cm) << id << " " << b.layout;
      EXPECT_LT(p.end_effector_mm, b.end_effector_mm) << id << " " << b.layout;
      // No shaking. With every limb tracked the fixed-lag smoother holds the shake near the
      // truth's (07_01, 6 sensors: 1.70 mm for 1.04; 5.9 mm without it); the bound leaves room for
      // rounding across compilers. Guessed legs (3 sensors) shake with their steps.
      if (std::string_view(b.layout) == "3") {
        EXPECT_LT(p.jitter_mm, p.jitter_truth_mm + 6.5) << id << " " << b.layout;
      } else {
        EXPECT_LT(p.jitter_mm, 2.0 * p.jitter_truth_mm + 0.8) << id << " " << b.layout;
      }
    }
  }
}

}  // namespace
}  // namespace mimic::solver::clip_accuracy_test
