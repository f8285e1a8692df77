// The baseline skinnings (LBS, DQS, CoR) on a cylinder around a two-bone chain: the properties
// each method is known for, including the failures they are baselines for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include "mimic/avatar/baselines/baseline_skinner.h"
#include "mimic/avatar/baselines/cor_skinning.h"
#include "mimic/avatar/baselines/dual_quaternion_skinning.h"
#include "mimic/avatar/baselines/linear_blend_skinning.h"
#include "mimic/avatar/mesh_check.h"
#include "two_bone_cylinder.h"

namespace mimic::avatar::baselines::baseline_skinning_test {
namespace {

using avatar::testing::cylinder_mesh;
using avatar::testing::two_bone_skeleton;
constexpr float kPi = std::numbers::pi_v<float>;
constexpr SkinningMethod kAll[] = {SkinningMethod::lbs, SkinningMethod::dqs, SkinningMethod::cor};

struct Rig {
  rig::Skeleton skeleton = two_bone_skeleton();
  Mesh rest = cylinder_mesh();
  std::vector<rig::RigidTransform> rest_w = std::vector<rig::RigidTransform>(2);
  BaselineSkinner skinner = make();

  BaselineSkinner make() {
    rig::forward_kinematics(skeleton, skeleton.zero_pose(), rest_w);
    auto s =
        BaselineSkinner::create(skeleton, rest_w, rest, weights_from_links(skeleton, rest_w, rest.positions, 0.08f));
    EXPECT_TRUE(s) << s.error().what();
    return std::move(*s);
  }
  // Posed vertices for elbow flexion and twist (radians).
  std::vector<glm::vec3> pose(SkinningMethod m, float flexion_rad, float twist_rad, rig::Pose base = {}) {
    rig::Pose p = base.dof_rad.empty() ? skeleton.zero_pose() : base;
    p.dof_rad[0] = flexion_rad, p.dof_rad[1] = twist_rad;
    std::vector<rig::RigidTransform> w(2);
    rig::forward_kinematics(skeleton, p, w);
    skinner.set_pose(w);
    std::vector<glm::vec3> out(skinner.vertex_count());
    skinner.deform(m, out);
    return out;
  }
};

float radius_yz(const glm::vec3& p) { return std::hypot(p.y, p.z); }

TEST(BaselineSkinning, LinksGiveWeightsThatSumToOneAndBlendOnlyNearTheElbow) {
  Rig r;
  const SkinWeights& w = r.skinner.weights();
  ASSERT_TRUE(validate_weights(w, 2));
  for (size_t v = 0; v < r.rest.positions.size(); ++v) {
    const float x = r.rest.positions[v].x;
    const float w_upper =
        (w.joints[4 * v] == 0 ? w.weights[4 * v] : 0) + (w.joints[4 * v + 1] == 0 ? w.weights[4 * v + 1] : 0);
    if (x < 0.21f) {
      EXPECT_EQ(w_upper, 1.0f) << x;
    } else if (x > 0.39f) {
      EXPECT_EQ(w_upper, 0.0f) << x;
    } else if (std::abs(x - 0.3f) < 1e-4f) {
      EXPECT_NEAR(w_upper, 0.5f, 1e-3f);
    }
  }
}

TEST(BaselineSkinning, ValidateWeightsNamesTheFaultyVertex) {
  SkinWeights w{{0, 0, 0, 0, 1, 0, 0, 0}, {1, 0, 0, 0, 0.9f, 0, 0, 0}};
  auto st = validate_weights(w, 2);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("vertex 1"), std::string::npos) << st.error().message;
  w.weights[4] = 1;
  EXPECT_TRUE(validate_weights(w, 2));
  w.joints[4] = 7;
  EXPECT_FALSE(validate_weights(w, 2));
  w.joints.pop_back();
  EXPECT_FALSE(validate_weights(w, 2));
}

TEST(BaselineSkinning, IdentityTransformsGiveTheRestPositions) {
  Rig r;
  for (SkinningMethod m : kAll) {
    const auto out = r.pose(m, 0, 0);
    for (size_t v = 0; v < out.size(); ++v)
      ASSERT_NEAR(glm::distance(out[v], r.rest.positions[v]), 0.0f, 1e-6f) << method_name(m) << " vertex " << v;
  }
}

TEST(BaselineSkinning, ASingleRigidJointMovesEveryVertexRigidly) {
  Rig r;
  // Everything bound to the root alone, then the root moved and turned.
  SkinWeights rigid;
  rigid.joints.assign(4 * r.rest.positions.size(), 0);
  rigid.weights.assign(4 * r.rest.positions.size(), 0.0f);
  for (size_t v = 0; v < r.rest.positions.size(); ++v) rigid.weights[4 * v] = 1.0f;
  auto s = BaselineSkinner::create(r.skeleton, r.rest_w, r.rest, rigid);
  ASSERT_TRUE(s);
  r.skinner = std::move(*s);
  rig::Pose base = r.skeleton.zero_pose();
  base.root_position_m = {0.4f, -1.2f, 2.0f};
  base.root_orientation = glm::normalize(glm::quat(0.3f, 0.5f, -0.7f, 0.2f));
  const rig::RigidTransform world_from_root{base.root_orientation, base.root_position_m};
  for (SkinningMethod m : kAll) {
    const auto out = r.pose(m, 1.0f, 0.5f, base);
    for (size_t v = 0; v < out.size(); ++v)
      ASSERT_NEAR(glm::distance(out[v], world_from_root.apply(r.rest.positions[v])), 0.0f, 2e-6f) << method_name(m);
  }
}

TEST(BaselineSkinning, DualQuaternionsOfPureRotationsKeepTheDistanceToTheJoint) {
  Rig r;
  const glm::vec3 elbow{0.3f, 0, 0};
  for (float flex : {0.5f, 1.5f, 2.6f}) {
    const auto out = r.pose(SkinningMethod::dqs, flex, 0.7f);
    for (size_t v = 0; v < out.size(); ++v)
      ASSERT_NEAR(glm::distance(out[v], elbow), glm::distance(r.rest.positions[v], elbow), 2e-6f) << flex;
  }
  // LBS does not: the blended vertices of the bent elbow are pulled in towards the joint.
  const auto lbs = r.pose(SkinningMethod::lbs, 2.6f, 0);
  float worst = 0;
  for (size_t v = 0; v < lbs.size(); ++v)
    worst = std::max(worst, glm::distance(r.rest.positions[v], elbow) - glm::distance(lbs[v], elbow));
  EXPECT_GT(worst, 0.01f);
}

TEST(BaselineSkinning, LinearBlendCollapsesToACandyWrapperAtAHalfTurnOfTwist) {
  Rig r;
  const auto lbs = r.pose(SkinningMethod::lbs, 0, kPi);
  const auto dqs = r.pose(SkinningMethod::dqs, 0, kPi * 0.999f);
  const auto cor = r.pose(SkinningMethod::cor, 0, kPi * 0.999f);
  float lbs_min = 1, dqs_min = 1, cor_min = 1;
  for (size_t v = 0; v + 2 < lbs.size(); ++v) {  // the last two are the caps' centres, on the axis
    lbs_min = std::min(lbs_min, radius_yz(lbs[v]));
    dqs_min = std::min(dqs_min, radius_yz(dqs[v]));
    cor_min = std::min(cor_min, radius_yz(cor[v]));
  }
  EXPECT_LT(lbs_min, 0.05f * 0.05f);  // the ring at the elbow shrinks to a point
  EXPECT_GT(dqs_min, 0.05f * 0.999f);
  EXPECT_GT(cor_min, 0.05f * 0.999f);
}

TEST(BaselineSkinning, CentresOfRotationLieOnTheAxisAndTwistLikeDualQuaternions) {
  Rig r;
  const auto centers = r.skinner.centers_of_rotation();
  const SkinWeights& w = r.skinner.weights();
  int blended = 0;
  for (size_t v = 0; v < centers.size(); ++v) {
    if (w.weights[4 * v] < 1.0f) {
      ++blended;
      EXPECT_LT(radius_yz(centers[v]), 1e-4f) << v;  // by symmetry, on the bone
      EXPECT_NEAR(centers[v].x, r.rest.positions[v].x, 0.03f);
    } else {
      EXPECT_EQ(centers[v], r.rest.positions[v]);  // one influence: plain LBS
    }
  }
  EXPECT_GT(blended, 100);
  const auto cor = r.pose(SkinningMethod::cor, 0, kPi / 2);
  const auto dqs = r.pose(SkinningMethod::dqs, 0, kPi / 2);
  for (size_t v = 0; v < cor.size(); ++v) ASSERT_NEAR(glm::distance(cor[v], dqs[v]), 0.0f, 2e-4f) << v;
}

TEST(BaselineSkinning, BentElbowVolumes) {
  // Whole closed cylinder at 120°: LBS loses volume, DQS and CoR keep it closer.
  Rig r;
  const double rest = analyze_topology(r.rest).signed_volume;
  auto volume = [&](SkinningMethod m) {
    Mesh posed = r.rest;
    posed.positions = r.pose(m, 2.1f, 0);
    return analyze_topology(posed).signed_volume / rest;
  };
  const double lbs = volume(SkinningMethod::lbs), dqs = volume(SkinningMethod::dqs), cor = volume(SkinningMethod::cor);
  EXPECT_LT(lbs, 0.99);
  EXPECT_GT(dqs, lbs);
  EXPECT_GT(cor, lbs);
}

TEST(BaselineSkinning, NormalsFollowTheRotation) {
  Rig r;
  rig::Pose p = r.skeleton.zero_pose();
  p.dof_rad[0] = 1.2f;
  std::vector<rig::RigidTransform> w(2);
  rig::forward_kinematics(r.skeleton, p, w);
  r.skinner.set_pose(w);
  std::vector<glm::vec3> pos(r.skinner.vertex_count()), nrm(pos.size());
  for (SkinningMethod m : kAll) {
    r.skinner.deform(m, pos, nrm);
    // A vertex of the forearm far from the elbow turns with the forearm alone.
    const size_t v = 58 * 48 + 3;
    EXPECT_NEAR(glm::distance(nrm[v], w[1].rotation * r.rest.normals[v]), 0.0f, 1e-5f) << method_name(m);
  }
}

TEST(BaselineSkinning, AntipodalQuaternionsAreTheSameRotation) {
  // Two joints with the same transform, one written with the negated quaternion (the same
  // rotation): any blend of them must be that transform, in the eight-wide blocks and the tail.
  const rig::RigidTransform t{glm::normalize(glm::quat(0.2f, 0.9f, -0.3f, 0.4f)), {0.1f, -0.2f, 0.3f}};
  DualQuat flipped = to_dual_quat(t);
  for (float& f : flipped.real) f = -f;
  for (float& f : flipped.dual) f = -f;
  const std::vector<DualQuat> dqs{to_dual_quat(t), flipped};
  const std::vector<SkinningMatrix> mats(2, to_skinning_matrix(t));
  const std::vector<glm::quat> rots{t.rotation, -t.rotation};
  std::vector<uint16_t> joints;
  std::vector<float> weights;
  std::vector<glm::vec3> in, normals, centers;
  for (int v = 0; v < 21; ++v) {
    const float w = 0.05f * float(v);
    // Alternate which slot holds the flipped joint, so each slot's sign test is exercised.
    if (v % 2)
      joints.insert(joints.end(), {0, 1, 0, 0});
    else
      joints.insert(joints.end(), {1, 0, 0, 0});
    weights.insert(weights.end(), {w, 1 - w, 0, 0});
    in.push_back({0.01f * float(v), 0.2f, -0.1f});
    normals.push_back(glm::normalize(glm::vec3{1, float(v), 2}));
    centers.push_back({0, 0.05f * float(v), 0});
  }
  std::vector<glm::vec3> out_p(in.size()), out_n(in.size());
  ASSERT_TRUE((DualQuaternionSkinningJob{dqs, joints, weights, in, normals, out_p, out_n}.Run()));
  for (size_t v = 0; v < in.size(); ++v) {
    EXPECT_NEAR(glm::distance(out_p[v], t.apply(in[v])), 0.0f, 2e-6f) << "dqs " << v;
    EXPECT_NEAR(glm::distance(out_n[v], t.rotation * normals[v]), 0.0f, 2e-6f) << "dqs " << v;
  }
  ASSERT_TRUE((CorSkinningJob{mats, rots, joints, weights, centers, in, normals, out_p, out_n}.Run()));
  for (size_t v = 0; v < in.size(); ++v) {
    EXPECT_NEAR(glm::distance(out_p[v], t.apply(in[v])), 0.0f, 2e-6f) << "cor " << v;
    EXPECT_NEAR(glm::distance(out_n[v], t.rotation * normals[v]), 0.0f, 2e-6f) << "cor " << v;
  }
}

// The jobs against a plain per-vertex reference written here with glm (blend, hemisphere test,
// normalise, transform), on random rotations (so flips are common), four non-zero weights per
// vertex and a vertex count that leaves a tail after the eight-wide blocks. Skeletons of 32
// joints take the per-frame flip table, of 80 the in-register dot products, of 300 CoR's
// per-vertex path: each must give the reference's vertices.
TEST(BaselineSkinning, EveryKernelPathEqualsThePlainReference) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (const size_t joint_count : {size_t{32}, size_t{80}, size_t{300}}) {
    std::vector<rig::RigidTransform> world(joint_count), inv(joint_count);
    for (auto& t : world) t = {glm::normalize(glm::quat(u(rng), u(rng), u(rng), u(rng))), {u(rng), u(rng), u(rng)}};
    std::vector<SkinningMatrix> mats(joint_count);
    std::vector<DualQuat> dqs(joint_count);
    std::vector<glm::quat> rots(joint_count);
    skinning_transforms(world, inv, mats, dqs, rots);
    const size_t n = 1003;
    std::vector<uint16_t> joints;
    std::vector<float> weights;
    std::vector<glm::vec3> in, normals, centers;
    std::uniform_int_distribution<int> pick(0, static_cast<int>(joint_count) - 1);
    for (size_t v = 0; v < n; ++v) {
      float w[4], sum = 0;
      for (float& x : w) sum += (x = 0.1f + std::abs(u(rng)));
      for (int k = 0; k < 4; ++k) joints.push_back(static_cast<uint16_t>(pick(rng))), weights.push_back(w[k] / sum);
      in.push_back({u(rng), u(rng), u(rng)});
      normals.push_back(glm::normalize(glm::vec3{u(rng), u(rng), u(rng)}));
      centers.push_back(in.back() + 0.2f * glm::vec3{u(rng), u(rng), u(rng)});
    }
    std::vector<glm::vec3> p(n), nr(n);
    const std::string what = std::to_string(joint_count) + " joints";
    ASSERT_TRUE((DualQuaternionSkinningJob{dqs, joints, weights, in, normals, p, nr}.Run()));
    size_t compared = 0;
    for (size_t v = 0; v < n; ++v) {
      const uint16_t* j = &joints[4 * v];
      const float* w = &weights[4 * v];
      glm::quat r(0, 0, 0, 0), d(0, 0, 0, 0);
      bool ambiguous = false;
      for (int k = 0; k < 4; ++k) {
        const glm::quat rk(dqs[j[k]].real[3], dqs[j[k]].real[0], dqs[j[k]].real[1], dqs[j[k]].real[2]);
        const glm::quat dk(dqs[j[k]].dual[3], dqs[j[k]].dual[0], dqs[j[k]].dual[1], dqs[j[k]].dual[2]);
        const glm::quat r0(dqs[j[0]].real[3], dqs[j[0]].real[0], dqs[j[0]].real[1], dqs[j[0]].real[2]);
        const float dot = glm::dot(r0, rk);
        ambiguous |= std::abs(dot) < 1e-3f;
        const float s = dot < 0 ? -w[k] : w[k];
        r = r + s * rk, d = d + s * dk;
      }
      if (ambiguous) continue;  // either hemisphere is right at a dot of zero
      ++compared;
      const float len = glm::length(r);
      r = r / len, d = d / len;
      const glm::quat t = 2.0f * d * glm::conjugate(r);  // translation of the normalised dual quaternion
      ASSERT_LT(glm::distance(p[v], r * in[v] + glm::vec3(t.x, t.y, t.z)), 2e-5f) << what << " dqs vertex " << v;
      ASSERT_LT(glm::distance(nr[v], r * normals[v]), 2e-5f) << what << " dqs normal " << v;
    }
    EXPECT_GT(compared, n * 9 / 10) << what;
    ASSERT_TRUE((CorSkinningJob{mats, rots, joints, weights, centers, in, normals, p, nr}.Run()));
    std::vector<glm::vec3> lp(n), ln(n);
    ASSERT_TRUE((LinearBlendSkinningJob{mats, joints, weights, in, normals, lp, ln}.Run()));
    for (size_t v = 0; v < n; ++v) {
      const uint16_t* j = &joints[4 * v];
      const float* w = &weights[4 * v];
      glm::quat q(0, 0, 0, 0);
      glm::mat4 m(0.0f);
      bool ambiguous = false;
      for (int k = 0; k < 4; ++k) {
        const float dot = glm::dot(rots[j[0]], rots[j[k]]);
        ambiguous |= std::abs(dot) < 1e-3f;
        q = q + (dot < 0 ? -w[k] : w[k]) * rots[j[k]];
        for (int c = 0; c < 4; ++c)
          m[c] += w[k] *
                  glm::vec4(mats[j[k]].cols[c][0], mats[j[k]].cols[c][1], mats[j[k]].cols[c][2], c == 3 ? 1.0f : 0.0f);
      }
      ASSERT_LT(glm::distance(lp[v], glm::vec3(m * glm::vec4(in[v], 1.0f))), 2e-5f) << what << " lbs vertex " << v;
      ASSERT_LT(glm::distance(ln[v], glm::vec3(m * glm::vec4(normals[v], 0.0f))), 2e-5f) << what << " lbs normal " << v;
      if (ambiguous) continue;
      q = glm::normalize(q);
      ASSERT_LT(glm::distance(p[v], q * (in[v] - centers[v]) + glm::vec3(m * glm::vec4(centers[v], 1.0f))), 2e-5f)
          << what << " cor vertex " << v;
      ASSERT_LT(glm::distance(nr[v], q * normals[v]), 2e-5f) << what << " cor normal " << v;
    }
  }
}

TEST(BaselineSkinning, JobsRejectMismatchedSpans) {
  std::vector<SkinningMatrix> mats(1, to_skinning_matrix({}));
  std::vector<glm::quat> rots(1);
  std::vector<DualQuat> dqs(1, to_dual_quat({}));
  std::vector<uint16_t> j(8, 0);
  std::vector<float> wt(8, 0.25f);
  std::vector<glm::vec3> in(2), out(1), cor(2);
  EXPECT_FALSE((LinearBlendSkinningJob{mats, j, wt, in, {}, out, {}}.Run()));
  EXPECT_FALSE((DualQuaternionSkinningJob{dqs, j, wt, in, {}, out, {}}.Run()));
  EXPECT_FALSE((CorSkinningJob{mats, rots, j, wt, cor, in, {}, out, {}}.Run()));
  out.resize(2);
  EXPECT_TRUE((LinearBlendSkinningJob{mats, j, wt, in, {}, out, {}}.Run()));
  EXPECT_TRUE((DualQuaternionSkinningJob{dqs, j, wt, in, {}, out, {}}.Run()));
  EXPECT_TRUE((CorSkinningJob{mats, rots, j, wt, cor, in, {}, out, {}}.Run()));
  EXPECT_FALSE((CorSkinningJob{mats, {}, j, wt, cor, in, {}, out, {}}.Run()));
}

}  // namespace
}  // namespace mimic::avatar::baselines::baseline_skinning_test
