#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "mimic/rig/bvh.h"
#include "mimic/core/file.h"
#include "test_data.h"

namespace mimic::rig::bvh_test {
namespace {

// Hand-written edge-case files live beside the tests (tests/data/bvh).
std::string local_data(const std::string& name) { return mimic::test::repo_test_data("bvh/" + name).string(); }

BvhClip load_ok(const std::string& path, double metres_per_unit = kCmuMetresPerUnit) {
  auto clip = load_bvh(path, BvhParseOptions{metres_per_unit});
  EXPECT_TRUE(clip) << (clip ? "" : clip.error().what());
  return clip ? *clip : BvhClip{};
}

std::string load_error(const std::string& name) {
  auto clip = load_bvh(local_data(name));
  EXPECT_FALSE(clip) << name << " should not parse";
  if (clip) return "";
  EXPECT_EQ(clip.error().code, Errc::parse_error);
  return clip.error().message;
}

std::vector<RigidTransform> fk(const BvhClip& clip, int frame) {
  std::vector<RigidTransform> w(clip.joints.size());
  bvh_forward_kinematics(clip, frame, w);
  return w;
}

glm::vec3 pos(const BvhClip& clip, const std::vector<RigidTransform>& w, const char* name) {
  const int j = clip.find_joint(name);
  EXPECT_GE(j, 0) << name;
  return j < 0 ? glm::vec3(0) : w[j].translation;
}

TEST(Bvh, ParsesEverySharedClip) {
  const std::map<std::string, int> frames = {{"07_01", 317},  {"09_11", 166},  {"02_04", 484}, {"02_05", 1855},
                                             {"02_06", 2236}, {"05_02", 1124}, {"06_04", 397}, {"13_26", 3029}};
  for (const char* id : test::kShared_clips) {
    SCOPED_TRACE(id);
    const BvhClip clip = load_ok(test::clip_path(id));
    EXPECT_EQ(clip.joints.size(), 31u);
    EXPECT_EQ(clip.channel_count, 96);
    EXPECT_EQ(clip.frame_count, frames.at(id));
    EXPECT_EQ(clip.values.size(), static_cast<size_t>(clip.frame_count) * 96);
    EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.0083333);
    EXPECT_EQ(clip.joints[0].name, "Hips");
    EXPECT_EQ(clip.joints[0].channels.size(), 6u);
    EXPECT_EQ(clip.joints[0].channels[3], BvhChannel::z_rotation);
    // Frame 0 is the converter's T-pose: thighs at Z ∓21°, upper arms at Z ∓8°.
    const auto row = clip.frame(0);
    const BvhJoint& lul = clip.joints[clip.find_joint("LeftUpLeg")];
    EXPECT_EQ(lul.channels[0], BvhChannel::z_rotation);
    EXPECT_EQ(row[lul.first_channel], -21.0);
    EXPECT_EQ(row[clip.joints[clip.find_joint("RightArm")].first_channel], 8.0);
    EXPECT_EQ(row[clip.joints[clip.find_joint("Neck")].first_channel + 2], -16.0);
    int end_sites = 0;
    for (const auto& j : clip.joints) end_sites += static_cast<int>(j.end_sites.size());
    EXPECT_EQ(end_sites, 7);
  }
}

TEST(Bvh, FrameZeroIsTheDocumentedTPose) {
  const BvhClip clip = load_ok(test::clip_path("07_01"));
  const auto w = fk(clip, 0);
  const glm::vec3 arm = pos(clip, w, "LeftArm"), hand = pos(clip, w, "LeftHand");
  const glm::vec3 d = glm::normalize(hand - arm);
  EXPECT_GT(d.x, 0.9f) << "left arm points +X";
  EXPECT_NEAR(glm::degrees(std::asin(d.y)), -8.0, 0.5) << "arms 8 degrees below horizontal";
  const glm::vec3 foot = pos(clip, w, "LeftFoot"), toe = pos(clip, w, "LeftToeBase");
  EXPECT_GT(toe.z, foot.z) << "toes point +Z";
  const glm::vec3 hip = pos(clip, w, "LeftUpLeg"), knee = pos(clip, w, "LeftLeg");
  EXPECT_NEAR(glm::degrees(std::acos(glm::normalize(hip - knee).y)), 0.0, 1.5) << "thigh vertical";
  // Table in the data README: subject 7 thigh 6.92 units.
  EXPECT_NEAR(glm::length(hip - knee), 6.92 * kCmuMetresPerUnit, 0.01 * kCmuMetresPerUnit);
}

TEST(Bvh, RootPositionIsScaledToMetres) {
  const BvhClip units = load_ok(test::clip_path("07_01"), 1.0);
  const BvhClip metres = load_ok(test::clip_path("07_01"));
  const auto wu = fk(units, 10), wm = fk(metres, 10);
  for (size_t j = 0; j < wu.size(); ++j)
    EXPECT_LT(glm::length(wu[j].translation * float(kCmuMetresPerUnit) - wm[j].translation), 1e-5f);
  EXPECT_NEAR(wu[0].translation.x, units.frame(10)[0], 1e-4);
}

TEST(Bvh, CrlfTabsTrailingSpacesAndOddChannelOrders) {
  const BvhClip clip = load_ok(local_data("edge_cases.bvh"), 1.0);
  ASSERT_EQ(clip.joints.size(), 4u);
  EXPECT_EQ(clip.channel_count, 11);
  EXPECT_EQ(clip.frame_count, 3);
  EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.0083333);
  const BvhJoint& dead = clip.joints[clip.find_joint("Dead")];
  EXPECT_TRUE(dead.channels.empty());
  ASSERT_EQ(dead.end_sites.size(), 1u);
  EXPECT_EQ(dead.end_sites[0], glm::dvec3(1.5, 0, 0));
  const auto row = clip.frame(1);
  EXPECT_EQ(row[3], 448.0) << "angles are kept unwrapped";
  EXPECT_EQ(row[4], -365.5);
  EXPECT_EQ(row[6], 12.0) << "'+12'";
  EXPECT_EQ(row[8], 10.0) << "'1e1'";

  // Chest lists Xrotation Zrotation Yrotation: its local rotation is Rx · Rz · Ry.
  const double k = glm::pi<double>() / 180.0;
  const glm::dquat expect = glm::angleAxis(12 * k, glm::dvec3(1, 0, 0)) *
                            glm::angleAxis(-0.25 * k, glm::dvec3(0, 0, 1)) *
                            glm::angleAxis(10 * k, glm::dvec3(0, 1, 0));
  const glm::dquat got = bvh_local_rotation(clip, clip.find_joint("Chest"), 1);
  EXPECT_NEAR(std::abs(glm::dot(got, expect)), 1.0, 1e-12);

  // Slider has a position channel on a non-root joint: it adds to the OFFSET.
  const auto w = fk(clip, 2);
  const glm::vec3 slider = pos(clip, w, "Slider");
  EXPECT_NEAR(slider.x, 2.0f, 1e-5);
  EXPECT_NEAR(slider.y, 10.0f - 1.0f - 1.0f, 1e-5);
  EXPECT_NEAR(slider.z, -4.0f, 1e-5);
}

TEST(Bvh, ForwardKinematicsFollowsTheStandardReading) {
  const BvhClip clip = load_ok(local_data("good_small.bvh"), 1.0);
  const auto w0 = fk(clip, 0), w1 = fk(clip, 1);
  EXPECT_LT(glm::length(w0[1].translation - glm::vec3(0, 5, 0)), 1e-6f);
  // Leg turns 30° about Z: its end site swings towards +X.
  const glm::vec3 tip = w1[1].apply(glm::vec3(clip.joints[1].end_sites[0]));
  EXPECT_NEAR(tip.x, 5.0f * std::sin(glm::radians(30.0f)), 1e-5);
  EXPECT_NEAR(tip.y, 5.0f - 5.0f * std::cos(glm::radians(30.0f)), 1e-5);
}

TEST(Bvh, MalformedOffsetNamesLineAndToken) {
  const std::string m = load_error("bad_offset.bvh");
  EXPECT_NE(m.find("bad_offset.bvh:8:"), std::string::npos) << m;
  EXPECT_NE(m.find("expected 3 numbers after OFFSET, got 'abc'"), std::string::npos) << m;
}

TEST(Bvh, FrameCountMismatch) {
  const std::string m = load_error("bad_frame_count.bvh");
  EXPECT_NE(m.find("bad_frame_count.bvh:17:"), std::string::npos) << m;
  EXPECT_NE(m.find("'Frames: 3' but the file has 2 frame lines"), std::string::npos) << m;
  const std::string extra = load_error("bad_extra_frame.bvh");
  EXPECT_NE(extra.find("bad_extra_frame.bvh:21:"), std::string::npos) << extra;
  EXPECT_NE(extra.find("more frame lines"), std::string::npos) << extra;
}

TEST(Bvh, TooFewOrTooManyValuesOnAMotionLine) {
  const std::string few = load_error("bad_short_row.bvh");
  EXPECT_NE(few.find("bad_short_row.bvh:20: frame 1 has too few values: 7 of the 9"), std::string::npos) << few;
  const std::string many = load_error("bad_long_row.bvh");
  EXPECT_NE(many.find("bad_long_row.bvh:20: frame 1 has too many values"), std::string::npos) << many;
}

TEST(Bvh, NonFiniteNumbersAreRejected) {
  const std::string m = load_error("bad_nan.bvh");
  EXPECT_NE(m.find("bad_nan.bvh:20:"), std::string::npos) << m;
  EXPECT_NE(m.find("non-finite value 'nan' in column 7"), std::string::npos) << m;
  auto overflow =
      parse_bvh("HIERARCHY\nROOT A\n{\nOFFSET 0 1e999 0\nCHANNELS 0\n}\nMOTION\nFrames: 0\nFrame Time: 1\n", "x.bvh");
  ASSERT_FALSE(overflow);
  EXPECT_NE(overflow.error().message.find("x.bvh:4: non-finite number '1e999'"), std::string::npos)
      << overflow.error().message;
  auto inf = parse_bvh(
      "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 1\nFrame Time: 1\ninf\n", "y.bvh");
  ASSERT_FALSE(inf);
  EXPECT_NE(inf.error().message.find("y.bvh:10:"), std::string::npos) << inf.error().message;
}

TEST(Bvh, UnbalancedBraces) {
  const std::string m = load_error("bad_braces.bvh");
  EXPECT_NE(m.find("unbalanced braces"), std::string::npos) << m;
  EXPECT_NE(m.find("bad_braces.bvh:15:"), std::string::npos) << m << " (the MOTION line)";
  auto extra = parse_bvh("HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\n}\nMOTION\n", "z.bvh");
  ASSERT_FALSE(extra);
  EXPECT_NE(extra.error().message.find("z.bvh:7:"), std::string::npos) << extra.error().message;
}

TEST(Bvh, UnknownChannel) {
  const std::string m = load_error("bad_channel.bvh");
  EXPECT_NE(m.find("bad_channel.bvh:9: unknown channel 'Wrotation'"), std::string::npos) << m;
}

TEST(Bvh, OtherStructuralErrorsNameTheirLine) {
  struct Case {
    const char* text;
    const char* expect;
  };
  const Case cases[] = {
      {"", "t.bvh:1: expected HIERARCHY, got end of file"},
      {"HIERARCHY\nROOT A\n{\nCHANNELS 0\n}\nMOTION\nFrames: 0\nFrame Time: 1\n",
       "t.bvh:5: joint 'A' (opened at line 2) has no OFFSET"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0\nCHANNELS 0\n}\n", "t.bvh:4: expected 3 numbers after OFFSET, got 2"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 7 Xrotation\n}\n", "t.bvh:5: expected a channel count 0..6"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation\n}\n", "t.bvh:5: CHANNELS 2 lists only 1"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Xrotation\n}\n",
       "t.bvh:5: channel 'Xrotation' listed twice"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\nJOINT A\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\n}\n",
       "t.bvh:6: duplicate joint name 'A'"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\n", "t.bvh:6: expected MOTION"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: x\n",
       "t.bvh:8: expected a number after 'Frames:', got 'x'"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: 1\nFrame Time: 0\n",
       "t.bvh:9: Frame Time must be positive"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: 1.5\n",
       "t.bvh:8: frame count must be a whole number"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 1\nFrame Time: 1\n0 x\n",
       "t.bvh:10: frame 0: expected a number in column 2, got 'x'"},
      {"HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 0\nWHAT\n}\n", "t.bvh:6: unexpected 'WHAT' in joint 'A'"},
  };
  for (const Case& c : cases) {
    auto r = parse_bvh(c.text, "t.bvh");
    ASSERT_FALSE(r) << c.text;
    EXPECT_NE(r.error().message.find(c.expect), std::string::npos) << "got: " << r.error().message;
  }
}

TEST(Bvh, BracesMayShareALineAndFramesMayBeEmpty) {
  auto r = parse_bvh(
      "HIERARCHY\nROOT Hips {\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition Zposition\n End Site { OFFSET 0 1 0 "
      "}\n}\nMOTION\nFrames:0\nFrame Time: 0.5\n",
      "b.bvh");
  ASSERT_TRUE(r) << r.error().what();
  EXPECT_EQ(r->frame_count, 0);
  EXPECT_EQ(r->joints[0].end_sites.size(), 1u);
}

// Every prefix and many single-byte corruptions of a valid file either parse or fail with a
// message naming the source; none crashes or reads garbage.
TEST(Bvh, TruncatedAndCorruptedInputNeverCrashes) {
  auto text = read_file(local_data("edge_cases.bvh"));
  ASSERT_TRUE(text);
  int ok = 0, failed = 0;
  for (size_t n = 0; n <= text->size(); ++n) {
    auto r = parse_bvh(std::string_view(*text).substr(0, n), "cut.bvh");
    if (r) {
      ++ok;
      EXPECT_EQ(r->values.size(), static_cast<size_t>(r->frame_count) * r->channel_count);
    } else {
      ++failed;
      EXPECT_EQ(r.error().message.rfind("cut.bvh:", 0), 0u) << r.error().message;
    }
  }
  EXPECT_GT(failed, 0);
  EXPECT_GT(ok, 0) << "the full file (and prefixes ending after the last frame) parse";
  std::mt19937_64 rng(12345);
  const char alphabet[] = "{}0123456789.-+eE \t\r\nXYZrotationpsJOINTEndSiteOFFSETCHANNELSnaif";
  for (int trial = 0; trial < 3000; ++trial) {
    std::string t = *text;
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int e = 0; e < edits; ++e) t[rng() % t.size()] = alphabet[rng() % (sizeof alphabet - 1)];
    auto r = parse_bvh(t, "mut.bvh");
    if (r) {
      EXPECT_EQ(r->values.size(), static_cast<size_t>(r->frame_count) * r->channel_count);
      for (double v : r->values) EXPECT_TRUE(std::isfinite(v));
    } else {
      EXPECT_EQ(r.error().message.rfind("mut.bvh:", 0), 0u) << r.error().message;
    }
  }
}

TEST(Bvh, ExportReadsBackToTheSamePositions) {
  auto skel = Skeleton::build(default_skeleton_desc());
  ASSERT_TRUE(skel);
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  std::vector<Pose> poses;
  for (int f = 0; f < 20; ++f) {
    Pose p = skel->zero_pose();
    for (auto& v : p.dof_rad) v = u(rng);
    p.root_position_m = {u(rng), 0.9f + 0.1f * u(rng), u(rng)};
    p.root_orientation = glm::normalize(glm::quat(u(rng), u(rng), u(rng), u(rng)));
    poses.push_back(p);
  }
  auto text = write_bvh(*skel, poses, 1.0 / 60.0);
  ASSERT_TRUE(text) << text.error().what();
  auto clip = parse_bvh(*text, "export.bvh");
  ASSERT_TRUE(clip) << clip.error().what();
  ASSERT_EQ(clip->joints.size(), static_cast<size_t>(skel->joint_count()));
  EXPECT_EQ(clip->frame_count, 20);
  EXPECT_NEAR(clip->frame_time_s, 1.0 / 60.0, 1e-9);
  EXPECT_EQ(clip->channel_count, 6 + skel->dof_count());
  std::vector<RigidTransform> wm(skel->joint_count()), wb(clip->joints.size());
  for (int f = 0; f < 20; ++f) {
    forward_kinematics(*skel, poses[f], wm);
    bvh_forward_kinematics(*clip, f, wb);
    for (int j = 0; j < skel->joint_count(); ++j) {
      const int b = clip->find_joint(skel->joint_name(j));
      ASSERT_GE(b, 0);
      EXPECT_LT(glm::length(wm[j].translation - wb[b].translation), 1e-4f) << skel->joint_name(j) << " frame " << f;
      EXPECT_GT(std::abs(glm::dot(wm[j].rotation, wb[b].rotation)), 1.0f - 1e-5f) << skel->joint_name(j);
    }
  }
}

TEST(Bvh, ExportRejectsSkewAxesAndMismatchedPoses) {
  SkeletonDesc d = default_skeleton_desc();
  d.joints[1].dofs[0].axis = glm::normalize(glm::vec3(1, 1, 0));
  auto skew = Skeleton::build(d);
  ASSERT_TRUE(skew);
  std::vector<Pose> poses{skew->zero_pose()};
  auto r = write_bvh(*skew, poses, 0.01);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("spine_lower_flexion"), std::string::npos) << r.error().message;
  auto skel = Skeleton::build(default_skeleton_desc());
  Pose wrong;
  wrong.dof_rad.resize(3);
  EXPECT_FALSE(write_bvh(*skel, std::span<const Pose>(&wrong, 1), 0.01));
}

}  // namespace
}  // namespace mimic::rig::bvh_test
