#include "mimic/solver/two_bone_ik.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mimic::solver::two_bone_ik_test {
namespace {

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

TEST(TwoBoneIk, ReachableTargetsAreReachedWithLinkLengthsKept) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int reached = 0;
  for (int k = 0; k < 1000; ++k) {
    TwoBoneIkJob job;
    job.start_m = {u(rng), u(rng), u(rng)};
    job.upper_m = 0.3f;
    job.lower_m = 0.25f;
    glm::vec3 dir(u(rng), u(rng), u(rng));
    if (glm::length(dir) < 0.1f) continue;
    const float d = 0.06f + 0.48f * 0.5f * (u(rng) + 1.0f);  // strictly inside [0.05, 0.55]
    job.target_m = job.start_m + glm::normalize(dir) * d;
    job.pole_dir = {u(rng), u(rng), u(rng)};
    ASSERT_TRUE(job.Run());
    EXPECT_TRUE(job.reached);
    EXPECT_LT(glm::length(job.end_m - job.target_m), 1e-4f);
    EXPECT_NEAR(glm::length(job.mid_m - job.start_m), 0.3f, 1e-4f);
    EXPECT_NEAR(glm::length(job.end_m - job.mid_m), 0.25f, 1e-4f);
    ++reached;
  }
  EXPECT_GT(reached, 900);
}

TEST(TwoBoneIk, MiddleJointSwivelsTowardsThePole) {
  TwoBoneIkJob job;
  job.start_m = {0, 0, 0};
  job.target_m = {0.4f, 0, 0};
  job.upper_m = job.lower_m = 0.25f;
  for (glm::vec3 pole : {glm::vec3(0, -1, 0), glm::vec3(0, 0, 1), glm::vec3(0.5f, 1, 0)}) {
    job.pole_dir = pole;
    ASSERT_TRUE(job.Run());
    const glm::vec3 perp = glm::normalize(glm::vec3(0, pole.y, pole.z));
    EXPECT_GT(glm::dot(glm::normalize(job.mid_m - glm::vec3(0.2f, 0, 0)), perp), 0.999f);
  }
}

TEST(TwoBoneIk, UnreachableTargetEndsAtTheNearestReach) {
  TwoBoneIkJob job;
  job.start_m = {0, 1, 0};
  job.upper_m = 0.3f;
  job.lower_m = 0.25f;
  job.target_m = {2, 1, 0};  // too far
  ASSERT_TRUE(job.Run());
  EXPECT_FALSE(job.reached);
  EXPECT_LT(glm::length(job.end_m - glm::vec3(0.55f, 1, 0)), 1e-4f);
  EXPECT_NEAR(job.bend_rad, 0.0f, 1e-2f);
  // Too near, with the bend limited to 150°: the end stops on the limit's sphere.
  job.target_m = {0.01f, 1, 0};
  job.max_bend_rad = glm::radians(150.0f);
  ASSERT_TRUE(job.Run());
  const float min_reach = std::sqrt(0.09f + 0.0625f + 2 * 0.3f * 0.25f * std::cos(glm::radians(150.0f)));
  EXPECT_NEAR(glm::length(job.end_m - job.start_m), min_reach, 1e-4f);
  EXPECT_LE(job.bend_rad, glm::radians(150.0f) + 1e-3f);
}

TEST(TwoBoneIk, DegenerateInputsGiveNoNaN) {
  TwoBoneIkJob job;
  job.upper_m = 0.3f;
  job.lower_m = 0.3f;
  job.start_m = job.target_m = {1, 1, 1};  // target on the start joint
  job.pole_dir = {0, 0, 0};                // and no pole
  ASSERT_TRUE(job.Run());
  EXPECT_TRUE(finite(job.mid_m) && finite(job.end_m));
  job.target_m = {1, 1.5f, 1};
  job.pole_dir = {0, 1, 0};  // pole along the axis
  ASSERT_TRUE(job.Run());
  EXPECT_TRUE(finite(job.mid_m) && finite(job.end_m));
  EXPECT_LT(glm::length(job.end_m - job.target_m), 1e-4f);
  job.upper_m = 0;  // zero-length bone chain is rejected
  EXPECT_FALSE(job.Validate());
  EXPECT_FALSE(job.Run());
  job.upper_m = 0.3f;
  job.target_m = {NAN, 0, 0};
  EXPECT_FALSE(job.Run());
}

}  // namespace
}  // namespace mimic::solver::two_bone_ik_test
