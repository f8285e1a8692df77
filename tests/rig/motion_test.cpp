#include <gtest/gtest.h>

#include <cmath>

#include "mimic/rig/motion.h"
#include "mimic/rig/retarget.h"
#include "test_data.h"

namespace mimic::rig::motion_test {
namespace {

Skeleton default_skeleton() {
  auto s = Skeleton::build(default_skeleton_desc());
  EXPECT_TRUE(s);
  return *s;
}

std::unique_ptr<Motion> make(const char* name, const Skeleton& s) {
  auto m = make_builtin_motion(name, s);
  EXPECT_TRUE(m) << m.error().what();
  return std::move(*m);
}

// Lowest sole point: 1.8 cm under the toe joints and toe tips, and under the heel (behind
// the ankle at the height of the sole), as standing_root_height_m measures it.
float lowest_sole(const Skeleton& s, std::span<const RigidTransform> w) {
  float lowest = 1e9f;
  for (const char* side : {"l_", "r_"}) {
    const int ankle = s.find_joint(std::string(side) + "ankle"), toes = s.find_joint(std::string(side) + "toes");
    const glm::vec3 down(0, -0.018f, 0);
    lowest = std::min(lowest, w[toes].apply(down).y);
    lowest = std::min(lowest, w[toes].apply(s.tip_m(toes) + down).y);
    lowest = std::min(lowest, w[ankle].apply(glm::vec3(0, s.offset_m(toes).y - 0.018f, -0.05f)).y);
  }
  return lowest;
}

TEST(Motion, NamesAndUnknownName) {
  EXPECT_EQ(builtin_motion_names(), (std::vector<std::string>{"idle", "walk", "run"}));
  auto m = make_builtin_motion("moonwalk", default_skeleton());
  ASSERT_FALSE(m);
  EXPECT_EQ(m.error().code, Errc::not_found);
  EXPECT_NE(m.error().message.find("moonwalk"), std::string::npos);
}

// The properties every built-in motion has, checked at 120 Hz over one loop and a bit. A motion
// with `flight` (a run) has both feet off the floor at times, the others always stand on it; no
// DOF turns more than `max_dof_step_deg` a sample (a runner's knee folds at 700–900°/s).
void check_motion(const Motion& m, double max_joint_step_m, bool flight = false, float max_dof_step_deg = 6.0f) {
  const Skeleton& s = m.skeleton();
  EXPECT_TRUE(m.loops());
  const double dt = 1.0 / 120.0;
  const int steps = static_cast<int>(std::ceil(m.duration_s() / dt)) + 24;
  Pose p = s.zero_pose(), prev = s.zero_pose();
  std::vector<RigidTransform> w(s.joint_count()), wp(s.joint_count());
  float lowest = 1e9f, highest_low = -1e9f, worst_step = 0;
  for (int i = 0; i <= steps; ++i) {
    m.sample(i * dt, p);
    forward_kinematics(s, p, w);
    for (int d = 0; d < s.dof_count(); ++d) {
      ASSERT_GE(p.dof_rad[d], s.dof(d).min_rad - 1e-6f) << s.dof(d).name << " t=" << i * dt;
      ASSERT_LE(p.dof_rad[d], s.dof(d).max_rad + 1e-6f) << s.dof(d).name << " t=" << i * dt;
    }
    const float sole = lowest_sole(s, w);
    lowest = std::min(lowest, sole);
    highest_low = std::max(highest_low, sole);
    if (i > 0) {
      for (int j = 0; j < s.joint_count(); ++j)
        worst_step = std::max(worst_step, glm::length(w[j].translation - wp[j].translation));
      for (int d = 0; d < s.dof_count(); ++d)
        ASSERT_LT(std::abs(p.dof_rad[d] - prev.dof_rad[d]), glm::radians(max_dof_step_deg))
            << s.dof(d).name << " t=" << i * dt;
    }
    std::swap(w, wp);
    prev = p;
  }
  EXPECT_LT(worst_step, max_joint_step_m) << "no joint jumps between 120 Hz samples";
  EXPECT_GT(lowest, -0.02f) << "feet never sink into the floor";
  if (flight)
    EXPECT_GT(highest_low, 0.03f) << "both feet leave the floor";
  else
    EXPECT_LT(highest_low, 0.02f) << "and never float above it";

  // Seamless loop: the end meets the start, and time wraps.
  Pose a = s.zero_pose(), b = s.zero_pose();
  m.sample(0.0, a);
  m.sample(m.duration_s() - 1e-6, b);
  EXPECT_LT(glm::length(a.root_position_m - b.root_position_m), 1e-4f);
  for (int d = 0; d < s.dof_count(); ++d) EXPECT_NEAR(a.dof_rad[d], b.dof_rad[d], 1e-4f) << s.dof(d).name;
  m.sample(0.37, a);
  m.sample(0.37 + 3 * m.duration_s(), b);
  EXPECT_LT(glm::length(a.root_position_m - b.root_position_m), 1e-4f);
  m.sample(0.37 - m.duration_s(), b);
  EXPECT_LT(glm::length(a.root_position_m - b.root_position_m), 1e-4f);
}

TEST(Motion, IdleIsContinuousLoopsStaysInLimitsAndOnTheFloor) {
  const auto m = make("idle", default_skeleton());
  EXPECT_EQ(m->name(), "idle");
  check_motion(*m, 0.01);
}

TEST(Motion, WalkIsContinuousLoopsStaysInLimitsAndOnTheFloor) {
  const auto m = make("walk", default_skeleton());
  EXPECT_EQ(m->name(), "walk");
  check_motion(*m, 0.06);
}

TEST(Motion, RunIsContinuousLoopsStaysInLimitsAndHasFlight) {
  const auto m = make("run", default_skeleton());
  EXPECT_EQ(m->name(), "run");
  check_motion(*m, 0.08, true, 9.0f);  // a running foot swings through at up to 8 m/s
}

// A run: each foot on the floor for a stance (left strike at 0, right at half a cycle), its ball
// planted at mid-stance; between the stances both feet in the air; the pelvis lowest at each
// mid-stance (so the head is too, which the solver's running gait reads) and faster than 2.5 m/s.
TEST(Motion, RunPlantsEachFootThenFlies) {
  const Skeleton s = default_skeleton();
  const auto m = make("run", s);
  const double cycle = 0.72, stance = 0.36;
  Pose p = s.zero_pose();
  std::vector<RigidTransform> w(s.joint_count());
  for (int k = 0; k < 2; ++k) {
    const int toes = s.find_joint(k == 0 ? "l_toes" : "r_toes");
    const double start = (k == 0 ? 0.0 : 0.5) * cycle + 3 * cycle;
    glm::vec3 first{0};
    float drift = 0;
    for (double t = start + 0.35 * stance * cycle; t < start + 0.65 * stance * cycle; t += 1.0 / 120) {
      m->sample(t, p);
      forward_kinematics(s, p, w);
      const glm::vec3 ball = w[toes].translation;
      if (first == glm::vec3(0)) first = ball;
      drift = std::max(drift, glm::length(ball - first));
      EXPECT_NEAR(ball.y, 0.018f, 0.006f) << "ball on the floor at mid-stance";
    }
    EXPECT_LT(drift, 0.01f) << "no foot sliding";
  }
  // Flight: halfway between one stance's end and the next strike, no sole near the floor.
  m->sample(3 * cycle + (stance + 0.5 - stance) * 0.5 * cycle + 0.5 * stance * cycle, p);
  forward_kinematics(s, p, w);
  EXPECT_GT(lowest_sole(s, w), 0.02f) << "both feet in the air";
  // The pelvis is lowest at mid-stance and highest in flight.
  Pose mid = s.zero_pose(), fly = s.zero_pose();
  m->sample(3 * cycle + 0.5 * stance * cycle, mid);
  m->sample(3 * cycle + (0.5 * stance + 0.25) * cycle, fly);
  EXPECT_LT(mid.root_position_m.y + 0.04f, fly.root_position_m.y);
  Pose a = s.zero_pose(), b = s.zero_pose();
  m->sample(1.0, a);
  m->sample(2.0, b);
  const float speed_mps =
      glm::length(glm::vec2(b.root_position_m.x - a.root_position_m.x, b.root_position_m.z - a.root_position_m.z));
  EXPECT_GT(speed_mps, 2.5f);
}

TEST(Motion, IdleStandsRelaxedWithFeetPlanted) {
  const Skeleton s = default_skeleton();
  const auto m = make("idle", s);
  Pose p = s.zero_pose();
  std::vector<RigidTransform> w(s.joint_count());
  glm::vec3 first_ankle{0};
  float max_drift = 0, min_breath = 1e9f, max_breath = -1e9f;
  for (double t = 0; t < m->duration_s(); t += 0.05) {
    m->sample(t, p);
    forward_kinematics(s, p, w);
    const glm::vec3 ankle = w[s.find_joint("l_ankle")].translation;
    if (t == 0) first_ankle = ankle;
    max_drift = std::max(max_drift, glm::length(ankle - first_ankle));
    for (const char* foot : {"l_ankle", "r_ankle"}) {
      const glm::vec3 toes_dir = w[s.find_joint(foot)].rotation * glm::vec3(0, 0, 1);
      EXPECT_GT(toes_dir.z, std::cos(glm::radians(1.0f))) << foot << " keeps pointing ahead, t=" << t;
    }
    const glm::vec3 arm =
        glm::normalize(w[s.find_joint("l_elbow")].translation - w[s.find_joint("l_shoulder")].translation);
    EXPECT_LT(arm.y, -0.9f) << "arms hang down";
    EXPECT_GT(glm::degrees(p.dof_rad[s.find_dof("l_elbow_flexion")]), 5.0f);
    const float chest = p.dof_rad[s.find_dof("spine_upper_flexion")];
    min_breath = std::min(min_breath, chest);
    max_breath = std::max(max_breath, chest);
  }
  EXPECT_LT(max_drift, 0.02f) << "the weight shift keeps the feet where they are";
  EXPECT_GT(max_breath - min_breath, glm::radians(1.0f)) << "breathing moves the chest";
  m->sample(3.0, p);
  const float root_low = p.root_position_m.y;
  m->sample(0.0, p);
  EXPECT_NEAR(p.root_position_m.y, standing_root_height_m(s), 0.02f);
  EXPECT_NE(root_low, 0.0f);
}

TEST(Motion, WalkGoesAroundACircleFacingTheWayItMoves) {
  const Skeleton s = default_skeleton();
  const auto m = make("walk", s);
  EXPECT_NEAR(std::fmod(m->duration_s(), 1.1), 0.0, 1e-9) << "a whole number of 1.1 s gait cycles per lap";
  Pose p = s.zero_pose(), q = s.zero_pose();
  float min_y = 1e9f, max_y = -1e9f;
  for (double t = 0; t < m->duration_s(); t += 0.1) {
    m->sample(t, p);
    const glm::vec2 xz(p.root_position_m.x, p.root_position_m.z);
    EXPECT_NEAR(glm::length(xz), 1.2f, 0.05f);
    m->sample(t + 0.05, q);
    const glm::vec3 v = q.root_position_m - p.root_position_m;
    const glm::vec3 facing = p.root_orientation * glm::vec3(0, 0, 1);
    EXPECT_GT(glm::dot(glm::normalize(glm::vec3(v.x, 0, v.z)), glm::normalize(glm::vec3(facing.x, 0, facing.z))), 0.9f);
    const float speed = glm::length(glm::vec2(v.x, v.z)) / 0.05f;
    EXPECT_GT(speed, 0.8f);
    EXPECT_LT(speed, 1.6f);
    min_y = std::min(min_y, p.root_position_m.y);
    max_y = std::max(max_y, p.root_position_m.y);
  }
  EXPECT_GT(max_y - min_y, 0.01f) << "the pelvis bobs";
  EXPECT_LT(max_y - min_y, 0.08f);
  // Legs alternate: each knee peaks in its own swing, half a cycle apart, and bends about as
  // far (not exactly: on a curve the inner and outer legs take different steps).
  float max_knee[2] = {0, 0};
  double peak_t[2] = {0, 0};
  for (double t = 0; t < 1.1; t += 0.005) {
    m->sample(t, p);
    for (int k = 0; k < 2; ++k) {
      const float v = p.dof_rad[s.find_dof(k == 0 ? "l_knee_flexion" : "r_knee_flexion")];
      if (v > max_knee[k]) {
        max_knee[k] = v;
        peak_t[k] = t;
      }
    }
  }
  EXPECT_GT(glm::degrees(max_knee[0]), 50.0f);
  EXPECT_NEAR(max_knee[0], max_knee[1], glm::radians(10.0f));
  const double apart = std::fmod(std::abs(peak_t[0] - peak_t[1]), 1.1);
  EXPECT_NEAR(apart, 0.55, 0.06);
}

TEST(Motion, WalkPlantsTheStanceFoot) {
  const Skeleton s = default_skeleton();
  const auto m = make("walk", s);
  Pose p = s.zero_pose();
  std::vector<RigidTransform> w(s.joint_count());
  // Flat-foot part of each stance (left heel strike at 0, right at half a cycle): the ball of
  // the foot stays put on the floor.
  for (int k = 0; k < 2; ++k) {
    const int toes = s.find_joint(k == 0 ? "l_toes" : "r_toes");
    const double start = (k == 0 ? 0.0 : 0.55) + 2 * 1.1;  // a later cycle, away from t = 0
    glm::vec3 first{0};
    float drift = 0;
    for (double t = start + 0.12 * 1.1; t < start + 0.55 * 1.1; t += 1.0 / 120) {
      m->sample(t, p);
      forward_kinematics(s, p, w);
      const glm::vec3 ball = w[toes].translation;
      if (drift == 0 && first == glm::vec3(0)) first = ball;
      drift = std::max(drift, glm::length(ball - first));
      EXPECT_NEAR(ball.y, 0.018f, 0.004f) << "ball on the floor";
    }
    EXPECT_LT(drift, 0.005f) << "no foot sliding";
  }
}

// The feet pass beside each other, never across: the left (outer) foot on the circle's outside
// of the right one at every sample of the lap, by about the two footprints' spacing. Each swing
// follows its foot's own circle; the chord of a stride (a sixth of the lap) cut 15 cm inwards,
// and the shins and feet passed through each other at every step of the outer leg.
TEST(Motion, WalkFeetPassBesideEachOtherNeverAcross) {
  const Skeleton s = default_skeleton();
  const auto m = make("walk", s);
  Pose p = s.zero_pose();
  std::vector<RigidTransform> w(s.joint_count());
  const int ankle[2] = {s.find_joint("l_ankle"), s.find_joint("r_ankle")};
  const int toes[2] = {s.find_joint("l_toes"), s.find_joint("r_toes")};
  float closest = 1e9f;
  for (double t = 0; t < m->duration_s(); t += 1.0 / 120) {
    m->sample(t, p);
    forward_kinematics(s, p, w);
    // Each foot's distance from the circle's centre, at its ankle and at its ball (a foot turns
    // along the curve, so both).
    for (int pick = 0; pick < 2; ++pick) {
      const int l = pick == 0 ? ankle[0] : toes[0], r = pick == 0 ? ankle[1] : toes[1];
      const float outer = glm::length(glm::vec2(w[l].translation.x, w[l].translation.z));
      const float inner = glm::length(glm::vec2(w[r].translation.x, w[r].translation.z));
      closest = std::min(closest, outer - inner);
    }
  }
  EXPECT_GT(closest, 0.14f) << "the feet come within " << closest << " m across the path";
}

TEST(Motion, Deterministic) {
  const Skeleton s = default_skeleton();
  for (const char* name : {"idle", "walk", "run"}) {
    const auto a = make(name, s), b = make(name, s);
    Pose pa = s.zero_pose(), pb = s.zero_pose();
    for (double t = 0; t < 5; t += 0.123) {
      a->sample(t, pa);
      b->sample(t, pb);
      EXPECT_EQ(pa.dof_rad, pb.dof_rad);
      EXPECT_EQ(pa.root_position_m, pb.root_position_m);
    }
  }
}

TEST(Motion, BuiltinsDriveAPerformersSkeletonToo) {
  auto clip = load_bvh(test::clip_path("06_04"));
  ASSERT_TRUE(clip);
  auto r = retarget_bvh(*clip);
  ASSERT_TRUE(r);
  for (const char* name : {"idle", "walk"}) {
    SCOPED_TRACE(name);
    check_motion(*make(name, r->skeleton), 0.06);
  }
}

}  // namespace
}  // namespace mimic::rig::motion_test
