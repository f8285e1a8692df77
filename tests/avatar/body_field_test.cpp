#include <gtest/gtest.h>

#include <random>

#include "mimic/avatar/body_field.h"

namespace mimic::avatar::body_field_test {
namespace {

// A one-joint skeleton with one rotational DOF, enough to carry test primitives.
rig::SkeletonDesc tiny_skeleton() {
  rig::SkeletonDesc d;
  d.joints.push_back({"root", "", {0, 0, 0}, {0, 1, 0}, {}});
  d.joints.push_back(
      {"arm", "root", {0, 0, 0}, {1, 0, 0}, {rig::DofDesc{"arm_flexion", {0, 0, 1}, -1.0f, 2.0f, 0.0f}}});
  return d;
}

BodyModel model_of(std::vector<Primitive> prims) {
  BodyModel m;
  m.skeleton = tiny_skeleton();
  m.primitives = std::move(prims);
  return m;
}

Primitive ball(const std::string& name, glm::vec3 c, glm::vec3 axes, GroupMask g = group_bit(Group::hip)) {
  Primitive p;
  p.name = name;
  p.joint = "root";
  p.state.center_m = c;
  p.state.semi_axes_m = axes;
  p.groups = g;
  return p;
}

BodyField field_of(const BodyModel& m) {
  auto s = rig::Skeleton::build(m.skeleton);
  EXPECT_TRUE(s);
  auto f = BodyField::create(m, *s);
  EXPECT_TRUE(f) << f.error().what();
  return std::move(*f);
}

std::vector<uint16_t> all(const BodyField& f) {
  std::vector<uint16_t> v;
  for (int i = 0; i < f.size(); ++i) v.push_back(static_cast<uint16_t>(i));
  return v;
}

TEST(DeformedState, InterpolatesWithEachFalloff) {
  PrimitiveState g0, gmin, gmax;
  g0.semi_axes_m = glm::vec3(1.0f);
  gmin.semi_axes_m = glm::vec3(0.5f);
  gmax.semi_axes_m = glm::vec3(3.0f);
  // θ0 = 0, limits [−1, 2]; halfway up (θ = 1) t = 0.5.
  EXPECT_NEAR(deformed_state(g0, gmin, gmax, Falloff::linear, 1.0f, 0, -1, 2).semi_axes_m.x, 2.0f, 1e-6);
  EXPECT_NEAR(deformed_state(g0, gmin, gmax, Falloff::parabolic, 1.0f, 0, -1, 2).semi_axes_m.x, 1.5f, 1e-6);
  EXPECT_NEAR(deformed_state(g0, gmin, gmax, Falloff::hyperbolic, 1.0f, 0, -1, 2).semi_axes_m.x,
              1.0f + 2.0f * std::sqrt(0.5f), 1e-6);
  EXPECT_NEAR(deformed_state(g0, gmin, gmax, Falloff::linear, -0.5f, 0, -1, 2).semi_axes_m.x, 0.75f, 1e-6);
  EXPECT_EQ(deformed_state(g0, gmin, gmax, Falloff::linear, 0.0f, 0, -1, 2).semi_axes_m, g0.semi_axes_m);
  EXPECT_EQ(deformed_state(g0, gmin, gmax, Falloff::linear, 2.0f, 0, -1, 2).semi_axes_m, gmax.semi_axes_m);
  EXPECT_EQ(deformed_state(g0, gmin, gmax, Falloff::linear, 9.0f, 0, -1, 2).semi_axes_m, gmax.semi_axes_m)
      << "beyond the limit the state saturates";
}

TEST(BodyField, LoneMetaballSurfaceIsItsEllipsoid) {
  const BodyField f = field_of(model_of({ball("b", {0.1f, 0.2f, 0.3f}, {0.05f, 0.1f, 0.2f})}));
  const auto cand = all(f);
  std::mt19937_64 rng(1);
  std::normal_distribution<float> n;
  for (int i = 0; i < 200; ++i) {
    const glm::vec3 d = glm::normalize(glm::vec3(n(rng), n(rng), n(rng)));
    const RayHit h = f.cast_outermost({0.1f, 0.2f, 0.3f}, d, cand);
    ASSERT_TRUE(h.hit());
    const glm::vec3 q = (h.t * d) / glm::vec3(0.05f, 0.1f, 0.2f);
    EXPECT_NEAR(glm::length(q), 1.0f, 1e-4f);
    EXPECT_NEAR(f.field({0.1f + h.t * d.x, 0.2f + h.t * d.y, 0.3f + h.t * d.z}, group_bit(Group::hip)), 1.0f, 1e-4f);
  }
}

TEST(BodyField, FindsAThinPartBeyondABigOne) {
  // A big ball at the origin and a thin plate far along +x: the outermost crossing is the plate's.
  const BodyField f =
      field_of(model_of({ball("big", {0, 0, 0}, glm::vec3(0.2f)), ball("thin", {0.6f, 0, 0}, {0.004f, 0.1f, 0.1f})}));
  const RayHit h = f.cast_outermost({0, 0, 0}, {1, 0, 0}, all(f));
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.t, 0.604f, 1e-4f);
}

TEST(BodyField, NothingBehindTheOriginIsHit) {
  const BodyField f = field_of(model_of({ball("b", {0, 0, 0}, glm::vec3(0.1f))}));
  EXPECT_FALSE(f.cast_outermost({0.5f, 0, 0}, {1, 0, 0}, all(f)).hit());
  const RayHit h = f.cast_outermost({-0.5f, 0, 0}, {1, 0, 0}, all(f));
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.t, 0.6f, 1e-4f) << "the far side is the outermost crossing";
}

TEST(BodyField, BlendedNeighboursJoinAndHardEllipsoidsUnite) {
  Primitive hard = ball("hard", {0, 0.3f, 0}, {0.05f, 0.05f, 0.05f});
  hard.kind = PrimitiveKind::ellipsoid;
  const BodyField f = field_of(
      model_of({ball("a", {-0.055f, 0, 0}, glm::vec3(0.05f)), ball("b", {0.055f, 0, 0}, glm::vec3(0.05f)), hard}));
  // Alone each ball ends 5 mm short of the midpoint; blended, the midpoint is inside.
  EXPECT_LT(f.field({0, 0, 0}, group_bit(Group::hip)) * 0.5f, 1.0f);
  EXPECT_TRUE(f.inside({0, 0, 0}, group_bit(Group::hip)));
  EXPECT_TRUE(f.inside({0, 0.33f, 0}, group_bit(Group::hip)));
  EXPECT_FALSE(f.inside({0, 0.36f, 0}, group_bit(Group::hip)));
  const RayHit h = f.cast_outermost({0, 0.3f, 0}, {0, 1, 0}, all(f));
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.t, 0.05f, 1e-5f);
}

TEST(BodyField, GroupsIsolatePrimitives) {
  const BodyField f =
      field_of(model_of({ball("left", {0.085f, 0, 0}, glm::vec3(0.08f), group_bit(Group::left_upper_leg)),
                         ball("right", {-0.085f, 0, 0}, glm::vec3(0.08f), group_bit(Group::right_upper_leg))}));
  EXPECT_EQ(f.field({0.2f, 0, 0}, group_bit(Group::right_upper_leg)), 0.0f);
  EXPECT_GT(f.field({0.085f, 0, 0}, group_bit(Group::left_upper_leg)), 1.0f);
  // Between the two, each group alone is below the iso-level; together they would blend.
  EXPECT_FALSE(f.inside({0, 0, 0}, group_bit(Group::left_upper_leg)));
  EXPECT_FALSE(f.inside({0, 0, 0}, group_bit(Group::right_upper_leg)));
  EXPECT_TRUE(f.inside({0, 0, 0}, group_bit(Group::left_upper_leg) | group_bit(Group::right_upper_leg)));
}

TEST(BodyField, DeformablePrimitiveFollowsItsDof) {
  Primitive m = ball("muscle", {0.2f, 0, 0}, {0.1f, 0.03f, 0.03f});
  m.joint = "arm";
  Deformation d;
  d.dof = "arm_flexion";
  d.at_min = m.state;
  d.at_max = m.state;
  d.at_max.semi_axes_m = {0.08f, 0.05f, 0.05f};
  m.deformation = d;
  BodyModel model = model_of({m});
  auto skel = rig::Skeleton::build(model.skeleton);
  auto f = BodyField::create(model, *skel);
  ASSERT_TRUE(f);
  rig::Pose p = skel->zero_pose();
  p.dof_rad[0] = 2.0f;  // the DOF's maximum: G = Gmax, and the joint has turned
  std::vector<rig::RigidTransform> w(skel->joint_count());
  rig::forward_kinematics(*skel, p, w);
  f->update(w, p.dof_rad);
  const glm::vec3 c = w[1].apply({0.2f, 0, 0});
  const RayHit h = f->cast_outermost(c, {0, 0, 1}, all(*f));
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.t, 0.05f, 1e-4f);
  EXPECT_NEAR(glm::distance(f->center(0), c), 0.0f, 1e-6f);
}

TEST(BodyField, BetweenTheThighsOfTheDefaultBodyIsNotSkin) {
  const BodyModel m = default_body_model();
  const BodyField f = field_of(m);
  // Zero posture, root at the origin: the thighs hang at x = ±0.11 m; mid-thigh is 0.3 m down.
  for (float y : {-0.2f, -0.3f, -0.4f}) {
    const glm::vec3 between{0, y, 0.0f};
    EXPECT_FALSE(f.inside(between, group_bit(Group::left_upper_leg))) << y;
    EXPECT_FALSE(f.inside(between, group_bit(Group::right_upper_leg))) << y;
    EXPECT_TRUE(f.inside({0.11f, y, 0}, group_bit(Group::left_upper_leg))) << y;
  }
}

// A ray from the left thigh's axis towards the crotch, in the hip group (both thighs): the
// outermost crossing is the far side of the right thigh, the nearest one to a point just
// outside the left thigh is the left thigh's own inner side.
TEST(BodyField, NearestCrossingStaysOnItsOwnThigh) {
  const BodyModel m = default_body_model();
  const BodyField f = field_of(m);
  std::vector<uint16_t> cand;
  for (int i = 0; i < f.size(); ++i)
    if (f.groups(i) & group_bit(Group::hip)) cand.push_back(static_cast<uint16_t>(i));
  // The left thigh's axis 0.18 m down, where the hip group's thigh primitives still reach (the
  // built-in body's hips sit where MakeHuman's are, 2.4 cm under the root).
  const glm::vec3 o{0.11f, -0.18f, 0.0f}, d{-1, 0, 0};
  const RayHit outer = f.cast_outermost(o, d, cand);
  ASSERT_TRUE(outer.hit());
  EXPECT_GT(outer.t, 0.2f) << "the outermost crossing lies on the other thigh";
  // A point in the gap, nearer the left thigh; the window reaches into the right one.
  const RayHit near = f.cast_nearest(o, d, cand, RayNear{0.09f, 0.03f, 0.2f});
  ASSERT_TRUE(near.hit());
  EXPECT_GT(near.t, 0.03f);
  EXPECT_LT(near.t, 0.09f) << "the left thigh's inner side";
  EXPECT_TRUE(f.inside(o + (near.t - 0.002f) * d, group_bit(Group::hip)));
  EXPECT_FALSE(f.inside(o + (near.t + 0.002f) * d, group_bit(Group::hip)));
}

}  // namespace
}  // namespace mimic::avatar::body_field_test

namespace mimic::avatar::body_field_test {
namespace {

// The default body's field in random postures (every DOF within ±0.5 rad), for comparing one
// caster with another.
struct RandomPostures {
  BodyModel model = default_body_model();
  rig::Skeleton skel = *rig::Skeleton::build(model.skeleton);
  BodyField field = *BodyField::create(model, skel);
  std::vector<rig::RigidTransform> w = std::vector<rig::RigidTransform>(skel.joint_count());
  std::mt19937_64 rng;
  std::uniform_real_distribution<float> u{-1.0f, 1.0f};
  explicit RandomPostures(uint64_t seed) : rng(seed) {}
  void next() {
    rig::Pose p = skel.zero_pose();
    for (int i = 0; i < skel.dof_count(); ++i) p.dof_rad[i] = 0.5f * u(rng);
    rig::forward_kinematics(skel, p, w);
    field.update(w, p.dof_rad);
  }
  // The primitives of two groups, picked by the trial's number.
  std::vector<uint16_t> two_groups(int trial, GroupMask& mask) const {
    mask = static_cast<GroupMask>((1u << (trial % kGroupCount)) | (1u << ((trial + 3) % kGroupCount)));
    std::vector<uint16_t> cand;
    for (int i = 0; i < field.size(); ++i)
      if (field.groups(i) & mask) cand.push_back(static_cast<uint16_t>(i));
    return cand;
  }
  // A ray from near a joint (picked by the trial's and the ray's numbers), in any direction.
  void add_ray(int trial, int j, std::vector<glm::vec3>& origins, std::vector<glm::vec3>& dirs) {
    origins.push_back(w[(trial + j) % skel.joint_count()].translation + 0.05f * glm::vec3(u(rng), u(rng), u(rng)));
    dirs.push_back(glm::normalize(glm::vec3(u(rng), u(rng), u(rng))));
  }
};

// The batched star caster (eight rays in lock step) finds what the one-ray caster finds.
TEST(BodyField, StarCastingAgreesWithSingleRays) {
  RandomPostures r(99);
  const BodyField* f = &r.field;
  auto& u = r.u;
  auto& rng = r.rng;
  const auto& w = r.w;
  int compared = 0, hits = 0;
  for (int trial = 0; trial < 60; ++trial) {
    r.next();
    const glm::vec3 origin = w[trial % r.skel.joint_count()].translation + 0.03f * glm::vec3(u(rng), u(rng), u(rng));
    const glm::vec3 normal = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)));
    const glm::vec3 front = glm::normalize(glm::cross(normal, glm::vec3(0.3f, 1, 0.2f)));
    const glm::vec3 left = glm::cross(normal, front);
    const GroupMask mask = static_cast<GroupMask>(1u << (trial % kGroupCount));
    std::vector<uint16_t> cand(256);
    cand.resize(f->candidates_near_plane(origin, normal, mask, cand));
    std::vector<float> angles, cos_a, sin_a;
    for (int j = 0; j < 29; ++j) angles.push_back(6.2831853f * float(j) / 29.0f + 0.01f * u(rng));
    for (float a : angles) cos_a.push_back(std::cos(a)), sin_a.push_back(std::sin(a));
    std::vector<RayHit> star(angles.size());
    f->cast_star(origin, front, left, cos_a, sin_a, cand, star);
    for (size_t j = 0; j < angles.size(); ++j) {
      const glm::vec3 d = std::cos(angles[j]) * front + std::sin(angles[j]) * left;
      const RayHit one = f->cast_outermost(origin, d, cand);
      ASSERT_EQ(one.hit(), star[j].hit()) << "trial " << trial << " ray " << j;
      if (one.hit()) {
        EXPECT_NEAR(one.t, star[j].t, 1e-4f) << "trial " << trial << " ray " << j;
        ++hits;
      }
      ++compared;
    }
  }
  EXPECT_GT(hits, 100) << "of " << compared << " rays";
}

// Rays of their own (each with its origin and direction), eight at a time: the same outermost
// crossings as one ray at a time, misses included.
TEST(BodyField, BatchedRaysAgreeWithSingleRays) {
  RandomPostures r(7);
  const BodyField* f = &r.field;
  int compared = 0, hits = 0, misses = 0;
  for (int trial = 0; trial < 100; ++trial) {
    r.next();
    GroupMask mask;
    const std::vector<uint16_t> cand = r.two_groups(trial, mask);
    // 1 to 21 rays (a partial last batch too), origins near joints, any direction.
    const int rays = 1 + trial % 21;
    std::vector<glm::vec3> origins, dirs;
    for (int j = 0; j < rays; ++j) r.add_ray(trial, j, origins, dirs);
    std::vector<RayHit> batch(static_cast<size_t>(rays));
    f->cast_rays(origins, dirs, cand, batch);
    for (int j = 0; j < rays; ++j) {
      const RayHit one = f->cast_outermost(origins[j], dirs[j], cand);
      ASSERT_EQ(one.hit(), batch[j].hit()) << "trial " << trial << " ray " << j;
      if (one.hit()) {
        EXPECT_NEAR(one.t, batch[j].t, 1e-4f) << "trial " << trial << " ray " << j;
        ++hits;
      } else {
        ++misses;
      }
      ++compared;
    }
  }
  EXPECT_GT(hits, 100) << "of " << compared << " rays";
  EXPECT_GT(misses, 0);
}

// The search near a point (boundary-driven rings): batched rays agree with single rays, and
// the single ray's answer is where the solid around the point ends (checked by dense sampling):
// from a point outside the first crossing inwards, from a point inside the first one outwards.
TEST(BodyField, NearestCrossingBatchedAgreesWithSingleAndEndsTheSolidAroundThePoint) {
  RandomPostures r(11);
  const BodyField* f = &r.field;
  auto& u = r.u;
  auto& rng = r.rng;
  int inwards = 0, outwards = 0, beyond = 0, misses = 0;
  for (int trial = 0; trial < 100; ++trial) {
    r.next();
    GroupMask mask;
    const std::vector<uint16_t> cand = r.two_groups(trial, mask);
    bool any_hard = false;
    for (uint16_t i : cand) any_hard = any_hard || f->hard(i);
    const int rays = 1 + trial % 21;
    std::vector<glm::vec3> origins, dirs;
    std::vector<RayNear> nears;
    for (int j = 0; j < rays; ++j) {
      r.add_ray(trial, j, origins, dirs);
      // Points around the outermost crossing, most windows holding one or more crossings.
      const RayHit out = f->cast_outermost(origins.back(), dirs.back(), cand);
      const float tn = (out.hit() ? out.t : 0.1f) * (0.9f + 0.4f * u(rng)) + 0.005f;
      const float reach = (0.2f + 0.3f * (0.5f + 0.5f * u(rng))) * tn;
      nears.push_back({tn, tn - reach, tn + reach});
    }
    std::vector<RayHit> batch(static_cast<size_t>(rays));
    f->cast_rays_nearest(origins, dirs, nears, cand, batch);
    for (int j = 0; j < rays; ++j) {
      const RayHit one = f->cast_nearest(origins[j], dirs[j], cand, nears[j]);
      const std::string what = "trial " + std::to_string(trial) + " ray " + std::to_string(j);
      ASSERT_EQ(one.hit(), batch[j].hit()) << what;
      if (one.hit()) {
        EXPECT_NEAR(one.t, batch[j].t, 1e-4f) << what;
      }
      if (any_hard) continue;  // a hard ellipsoid's exit competes by distance alone
      // Sampled every 0.2 mm from the point: the first change of side, inwards or outwards.
      const RayNear& n = nears[j];
      auto inside = [&](float t) { return f->inside(origins[j] + t * dirs[j], mask); };
      const bool in0 = inside(n.t_near);
      float first = -1.0f;
      for (float t = n.t_near; in0 ? t <= n.t_max : t >= n.t_min; t += in0 ? 2e-4f : -2e-4f) {
        if (inside(t) != in0) {
          first = t;
          break;
        }
      }
      if (first < 0.0f) {
        if (in0) {
          EXPECT_EQ(one.t, n.t_max) << what;
          ++beyond;
        } else {
          EXPECT_FALSE(one.hit()) << what;
          ++misses;
        }
        continue;
      }
      ASSERT_TRUE(one.hit()) << what;
      EXPECT_NEAR(one.t, first, 5e-4f) << what;
      ++(in0 ? outwards : inwards);
    }
  }
  std::printf("near a point: %d crossings inwards, %d outwards, %d beyond the window, %d misses\n", inwards, outwards,
              beyond, misses);
  EXPECT_GT(inwards, 20);
  EXPECT_GT(outwards, 20);
  EXPECT_GT(beyond, 0);
  EXPECT_GT(misses, 0);
}

}  // namespace
}  // namespace mimic::avatar::body_field_test
