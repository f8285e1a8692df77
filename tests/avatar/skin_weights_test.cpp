#include "mimic/avatar/skin_weights.h"

#include <gtest/gtest.h>

#include "mimic/rig/motion.h"
#include "mimic/avatar/skin.h"

namespace mimic::avatar::skin_weights_test {
namespace {

ImplicitSkin realtime_resolution() {
  SkinOptions o;
  o.subdivision = 0;
  auto s = ImplicitSkin::create(default_body_model(), o);
  EXPECT_TRUE(s) << s.error().what();
  return std::move(*s);
}

float weight_of(const JointInfluences& in, int joint) {
  for (int i = 0; i < JointInfluences::kMax; ++i)
    if (in.weight[i] > 0 && in.joint[i] == joint) return in.weight[i];
  return 0.0f;
}

TEST(SkinWeights, EveryVertexHasAtMostFourNormalisedInfluences) {
  const ImplicitSkin s = realtime_resolution();
  auto w = contour_skin_weights(s);
  ASSERT_TRUE(w) << w.error().what();
  ASSERT_EQ(w->size(), s.mesh().positions.size());
  for (size_t v = 0; v < w->size(); ++v) {
    const JointInfluences& in = (*w)[v];
    float sum = 0;
    for (int i = 0; i < JointInfluences::kMax; ++i) {
      EXPECT_GE(in.weight[i], 0.0f);
      if (i > 0) {
        EXPECT_LE(in.weight[i], in.weight[i - 1]) << "descending, vertex " << v;
      }
      if (in.weight[i] > 0) {
        EXPECT_LT(in.joint[i], s.skeleton().joint_count());
      }
      sum += in.weight[i];
    }
    EXPECT_NEAR(sum, 1.0f, 1e-5f) << "vertex " << v;
  }
}

TEST(SkinWeights, FollowTheRingsAlongTheLinks) {
  const ImplicitSkin s = realtime_resolution();
  const rig::Skeleton& sk = s.skeleton();
  auto w = contour_skin_weights(s);
  ASSERT_TRUE(w);
  const int shoulder = sk.find_joint("l_shoulder"), elbow = sk.find_joint("l_elbow");
  // The contour rings: mid upper arm belongs to the shoulder alone, the elbow ring is shared
  // 50/50, mid forearm belongs to the elbow alone; the hand is rigid on the wrist.
  std::vector<rig::RigidTransform> rest(sk.joint_count());
  rig::forward_kinematics(sk, sk.zero_pose(), rest);
  const glm::vec3 shoulder_p = rest[shoulder].translation, elbow_p = rest[elbow].translation;
  const glm::vec3 wrist_p = rest[sk.find_joint("l_wrist")].translation;
  int mid_upper = 0, at_elbow = 0, mid_lower = 0;
  const auto& pos = s.mesh().positions;
  for (size_t v = 0; v < pos.size(); ++v) {
    const auto along = [&](glm::vec3 a, glm::vec3 b) { return glm::dot(pos[v] - a, b - a) / glm::dot(b - a, b - a); };
    const float up = along(shoulder_p, elbow_p), lo = along(elbow_p, wrist_p);
    if (pos[v].x < shoulder_p.x + 0.02f || std::abs(pos[v].y - elbow_p.y) > 0.09f) continue;  // the left arm
    if (std::abs(up - 0.55f) < 0.12f) {
      EXPECT_FLOAT_EQ(weight_of((*w)[v], shoulder), 1.0f);
      ++mid_upper;
    }
    if (std::abs(lo) < 0.01f) {
      EXPECT_NEAR(weight_of((*w)[v], elbow), 0.5f, 0.05f);
      ++at_elbow;
    }
    if (std::abs(lo - 0.5f) < 0.12f) {
      EXPECT_FLOAT_EQ(weight_of((*w)[v], elbow), 1.0f);
      ++mid_lower;
    }
  }
  EXPECT_GT(mid_upper, 10);
  EXPECT_GT(at_elbow, 10);
  EXPECT_GT(mid_lower, 10);
  // Rigid parts: every vertex of the head on the head joint alone.
  const int head = sk.find_joint("head");
  int head_vertices = 0;
  for (size_t v = 0; v < pos.size(); ++v)
    if (glm::distance(pos[v], rest[head].translation) < 0.05f && (*w)[v].weight[0] == 1.0f && (*w)[v].joint[0] == head)
      ++head_vertices;
  EXPECT_GT(head_vertices, 0);
}

// Linear blend skinning with these weights tracks the contour skin through a walk: a mean
// distance of a few centimetres would mean the weights bind vertices to the wrong links.
TEST(SkinWeights, LinearBlendWithThemStaysNearTheContourSkin) {
  ImplicitSkin s = realtime_resolution();
  const rig::Skeleton& sk = s.skeleton();
  auto w = contour_skin_weights(s);
  ASSERT_TRUE(w);
  std::vector<rig::RigidTransform> rest(sk.joint_count()), now(sk.joint_count());
  rig::forward_kinematics(sk, sk.zero_pose(), rest);
  const std::vector<glm::vec3> rest_pos = s.mesh().positions;
  auto motion = rig::make_builtin_motion("walk", sk);
  ASSERT_TRUE(motion);
  rig::Pose p = sk.zero_pose();
  double sum = 0;
  size_t n = 0;
  for (int f = 0; f < 20; ++f) {
    (*motion)->sample(0.05 * f, p);
    s.evaluate(p);
    rig::forward_kinematics(sk, p, now);
    for (size_t v = 0; v < rest_pos.size(); ++v) {
      glm::vec3 q(0);
      for (int i = 0; i < JointInfluences::kMax; ++i) {
        const int j = (*w)[v].joint[i];
        q += (*w)[v].weight[i] * now[j].apply(rest[j].inverse().apply(rest_pos[v]));
      }
      sum += glm::distance(q, s.mesh().positions[v]);
      ++n;
    }
  }
  EXPECT_LT(sum / static_cast<double>(n), 0.012) << "mean distance, metres";
}

TEST(SkinWeights, NeedTheRealtimeResolution) {
  auto s = ImplicitSkin::create(default_body_model(), SkinOptions{});
  ASSERT_TRUE(s);
  EXPECT_FALSE(contour_skin_weights(*s));
}

}  // namespace
}  // namespace mimic::avatar::skin_weights_test
