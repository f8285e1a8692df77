// The lean pose stream: bytes per avatar-frame and the error bound over every frame of every
// shared clip, the reference rule (a delta never applies to the wrong frame), recovery by key
// frames after a lost datagram or skipped frames, and hostile packets.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "mimic/rig/retarget.h"
#include "mimic/net/pose_stream.h"
#include "test_data.h"

namespace mimic::net::pose_stream_test {
namespace {

using Bytes = std::vector<uint8_t>;

Bytes pose_packet(const PoseHeader& h, const rig::Pose& p) {
  Bytes b(kMaxDatagramBytes);
  b.resize(encode_pose(h, p, b));
  return b;
}

// The documented bound: (2^shift + 1)/2 steps of the POSE frame's quantisation.
double bound_steps(uint8_t shift) { return (double(1u << shift) + 1.0) / 2.0; }

double wrapped(double a) { return std::remainder(a, 2.0 * M_PI); }

struct Clip {
  std::string id;
  std::vector<rig::Pose> frames;  // sampled at 90 Hz, as the pipeline streams it
};

std::vector<Clip> shared_clips_at_90hz() {
  std::vector<Clip> clips;
  for (const char* id : ::mimic::test::kShared_clips) {
    auto m = rig::load_bvh_motion(::mimic::test::clip_path(id));
    EXPECT_TRUE(m) << id << ": " << m.error().what();
    if (!m) continue;
    Clip c{id, {}};
    rig::Pose pose = (*m)->skeleton().zero_pose();
    for (int k = 0; k / 90.0 <= (*m)->duration_s(); ++k) {
      (*m)->sample(k / 90.0, pose);
      c.frames.push_back(pose);
    }
    clips.push_back(std::move(c));
  }
  return clips;
}

void expect_within_bound(const rig::Pose& got, const rig::Pose& want, uint8_t shift, const std::string& where) {
  const double steps = bound_steps(shift);
  ASSERT_EQ(got.dof_rad.size(), want.dof_rad.size()) << where;
  for (size_t i = 0; i < want.dof_rad.size(); ++i) {
    ASSERT_LE(std::abs(wrapped(double(got.dof_rad[i]) - double(want.dof_rad[i]))), steps * kAngleStep_rad + 1e-6)
        << where << " dof " << i;
  }
  for (int a = 0; a < 3; ++a) {
    ASSERT_LE(std::abs(double(got.root_position_m[a]) - double(want.root_position_m[a])),
              steps * kRootPositionStep_m + 1e-6 * std::abs(double(want.root_position_m[a])) + 1e-7)
        << where << " root axis " << a;
  }
  // Quaternion components within the bound before renormalisation: after it, the 4-vector
  // differs by at most twice the error's length.
  glm::quat w = glm::normalize(want.root_orientation);
  if (w.w < 0) w = -w;
  const glm::quat d = got.root_orientation - w;
  ASSERT_LE(std::sqrt(double(glm::dot(d, d))), 2.0 * 2.0 * steps * kQuatStep * 1.001) << where << " orientation";
}

TEST(PoseStream, EverySharedClipRoundTripsWithinTheBoundUnder64BytesPerFrame) {
  const auto clips = shared_clips_at_90hz();
  ASSERT_EQ(clips.size(), std::size(::mimic::test::kShared_clips));
  uint64_t total_bytes = 0, total_frames = 0, keys = 0;
  for (const Clip& c : clips) {
    LeanPoseEncoder enc;  // default precision, a key every 90 frames
    LeanPoseState rx;
    rig::Pose got;
    uint64_t bytes = 0;
    uint64_t time_us = 1'700'000'000'000'000;
    for (size_t k = 0; k < c.frames.size(); ++k) {
      const uint32_t seq = uint32_t(k + 1);
      time_us += 11111;
      const Bytes v2 = pose_packet({7, 0, seq, time_us}, c.frames[k]);
      ASSERT_TRUE(enc.update(v2));
      const auto p = enc.packet_for(rx.valid ? rx.sequence : 0);
      ASSERT_FALSE(p.empty());
      keys += lean_pose_is_key(p);
      bytes += p.size();
      PoseHeader h;
      ASSERT_EQ(decode_lean_pose(p, rx, h, got), Reject::ok) << c.id << " frame " << k;
      ASSERT_EQ(h.sequence, seq);
      ASSERT_EQ(h.avatar, 7);
      ASSERT_EQ(h.time_us, time_us);
      // The receiver's state is the encoder's, bit for bit.
      for (size_t i = 0; i < rx.value_count(); ++i) {
        ASSERT_EQ(rx.current[i], enc.state().current[i]) << c.id << " frame " << k << " value " << i;
        ASSERT_EQ(rx.previous[i], enc.state().previous[i]) << c.id << " frame " << k << " value " << i;
      }
      expect_within_bound(got, c.frames[k], kDefaultPoseShift, c.id + " frame " + std::to_string(k));
    }
    std::printf("  %s: %zu frames, %.1f bytes per avatar-frame (POSE: %zu)\n", c.id.c_str(), c.frames.size(),
                double(bytes) / double(c.frames.size()), pose_packet_bytes(c.frames[0].dof_rad.size()));
    total_bytes += bytes;
    total_frames += c.frames.size();
  }
  const double mean = double(total_bytes) / double(total_frames);
  std::printf("  all clips: %.1f bytes per avatar-frame over %llu frames (%llu key frames)\n", mean,
              static_cast<unsigned long long>(total_frames), static_cast<unsigned long long>(keys));
  EXPECT_LE(mean, 64.0);
}

TEST(PoseStream, FullPrecisionIsLosslessAgainstThePoseFrame) {
  const auto clips = shared_clips_at_90hz();
  ASSERT_FALSE(clips.empty());
  LeanPoseEncoder enc(0);
  LeanPoseState rx;
  rig::Pose got, want;
  PoseHeader h, vh;
  for (size_t k = 0; k < clips[0].frames.size(); ++k) {
    const Bytes v2 = pose_packet({1, 0, uint32_t(k + 1), 5}, clips[0].frames[k]);
    ASSERT_EQ(decode_pose(v2, vh, want), Reject::ok);
    ASSERT_TRUE(enc.update(v2));
    ASSERT_EQ(decode_lean_pose(enc.packet_for(rx.sequence), rx, h, got), Reject::ok);
    for (size_t i = 0; i < want.dof_rad.size(); ++i) ASSERT_EQ(got.dof_rad[i], want.dof_rad[i]) << k;
    for (int a = 0; a < 3; ++a) ASSERT_FLOAT_EQ(got.root_position_m[a], want.root_position_m[a]) << k;
  }
}

// Frames of a real clip through a lossy link: the receiver never applies a delta to the wrong
// frame, and a key frame (asked for, or the periodic one) brings it back exactly.
TEST(PoseStream, LostDatagramIsRefusedUntilAKeyFrameRecoversExactly) {
  const auto clips = shared_clips_at_90hz();
  ASSERT_FALSE(clips.empty());
  const auto& frames = clips.back().frames;
  ASSERT_GT(frames.size(), 400u);
  LeanPoseEncoder enc(kDefaultPoseShift, 90);
  LeanPoseState rx;
  rig::Pose got;
  PoseHeader h;
  auto feed = [&](size_t k) {
    const Bytes v2 = pose_packet({2, 0, uint32_t(k + 1), 1000 * k}, frames[k]);
    EXPECT_TRUE(enc.update(v2));
  };
  // In step up to frame 20.
  for (size_t k = 0; k < 20; ++k) {
    feed(k);
    ASSERT_EQ(decode_lean_pose(enc.packet_for(rx.sequence), rx, h, got), Reject::ok);
  }
  // Frame 20's datagram is lost: 21's delta does not follow the receiver's state.
  feed(20);
  ASSERT_FALSE(lean_pose_is_key(enc.packet_for(20)));
  feed(21);
  const LeanPoseState before = rx;
  const auto delta21 = enc.delta();
  ASSERT_FALSE(delta21.empty());
  EXPECT_EQ(decode_lean_pose(delta21, rx, h, got), Reject::unexpected);
  EXPECT_EQ(rx.sequence, before.sequence);
  EXPECT_EQ(rx.current, before.current);
  // On request (the receiver says it is at 20), the server sends the key of the current frame.
  feed(22);
  const auto key = enc.packet_for(rx.sequence);
  ASSERT_TRUE(lean_pose_is_key(key));
  ASSERT_EQ(decode_lean_pose(key, rx, h, got), Reject::ok);
  EXPECT_EQ(h.sequence, 23u);
  expect_within_bound(got, frames[22], kDefaultPoseShift, "key after loss");
  // Deltas apply again, exactly.
  for (size_t k = 23; k < 60; ++k) {
    feed(k);
    const auto p = enc.packet_for(rx.sequence);
    ASSERT_FALSE(lean_pose_is_key(p)) << k;
    ASSERT_EQ(decode_lean_pose(p, rx, h, got), Reject::ok) << k;
    expect_within_bound(got, frames[k], kDefaultPoseShift, "after recovery " + std::to_string(k));
  }
  // Without a request: the receiver lost frame 60 and refuses every delta until the periodic
  // key (sequence 90), which everyone gets.
  feed(60);
  size_t refused = 0;
  for (size_t k = 61; k < 100; ++k) {
    feed(k);
    const auto p = enc.delta().empty() ? enc.key() : enc.delta();  // what an up-to-date receiver gets
    const Reject e = decode_lean_pose(p, rx, h, got);
    if (k + 1 < 90) {
      ASSERT_EQ(e, Reject::unexpected) << k;
      ++refused;
    } else {
      ASSERT_EQ(e, Reject::ok) << k;
      if (k + 1 == 90) {
        EXPECT_TRUE(lean_pose_is_key(p));
      }
      expect_within_bound(got, frames[k], kDefaultPoseShift, "after periodic key " + std::to_string(k));
    }
  }
  EXPECT_EQ(refused, 28u);
  // A key older than what the receiver holds (a reordered datagram) is refused too.
  LeanPoseEncoder old_enc;
  old_enc.update(pose_packet({2, 0, 50, 0}, frames[50]));
  EXPECT_EQ(decode_lean_pose(old_enc.key(), rx, h, got), Reject::out_of_order);
}

// Latest wins: a subscriber the server skipped frames for gets the key of the frame it is sent.
TEST(PoseStream, SkippedFramesGetTheKeyOfTheFrameSent) {
  const auto clips = shared_clips_at_90hz();
  ASSERT_FALSE(clips.empty());
  const auto& frames = clips[1].frames;
  LeanPoseEncoder enc(kDefaultPoseShift, 0);
  LeanPoseState fast, slow;
  rig::Pose got;
  PoseHeader h;
  for (size_t k = 0; k < 200; ++k) {
    ASSERT_TRUE(enc.update(pose_packet({3, 0, uint32_t(k + 1), 0}, frames[k])));
    ASSERT_EQ(decode_lean_pose(enc.packet_for(fast.sequence), fast, h, got), Reject::ok);
    if (k % 7 == 0) {  // the slow one gets every seventh frame
      const auto p = enc.packet_for(slow.sequence);
      EXPECT_TRUE(lean_pose_is_key(p)) << k;
      ASSERT_EQ(decode_lean_pose(p, slow, h, got), Reject::ok) << k;
      expect_within_bound(got, frames[k], kDefaultPoseShift, "slow " + std::to_string(k));
    }
  }
}

TEST(PoseStream, DamagedPacketsAreRefusedAndLeaveTheStateAlone) {
  const auto clips = shared_clips_at_90hz();
  ASSERT_FALSE(clips.empty());
  const auto& frames = clips[2].frames;
  LeanPoseEncoder enc;
  LeanPoseState rx;
  rig::Pose got;
  PoseHeader h;
  for (size_t k = 0; k < 10; ++k) {
    enc.update(pose_packet({4, 0, uint32_t(k + 1), 0}, frames[k]));
    ASSERT_EQ(decode_lean_pose(enc.packet_for(rx.sequence), rx, h, got), Reject::ok);
  }
  enc.update(pose_packet({4, 0, 11, 0}, frames[10]));
  const Bytes delta(enc.delta().begin(), enc.delta().end());
  const Bytes key(enc.key().begin(), enc.key().end());
  const LeanPoseState kept = rx;
  for (const Bytes* p : {&delta, &key}) {
    for (size_t n = 0; n < p->size(); ++n) {
      LeanPoseState s = kept;
      EXPECT_NE(decode_lean_pose(std::span<const uint8_t>(*p).first(n), s, h, got), Reject::ok) << n;
      EXPECT_EQ(s.sequence, kept.sequence);
    }
    Bytes longer = *p;
    longer.push_back(0);
    longer[4]++;  // the header says so too
    LeanPoseState s = kept;
    EXPECT_EQ(decode_lean_pose(longer, s, h, got), Reject::malformed);
  }
  // Random damage never crashes, and whatever is accepted decodes to values in range.
  std::mt19937 rng(3);
  int accepted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Bytes b = trial % 2 ? delta : key;
    for (int f = 0; f < 3; ++f) b[kHeaderBytes + rng() % (b.size() - kHeaderBytes)] ^= uint8_t(1u << (rng() % 8));
    LeanPoseState s = kept;
    if (decode_lean_pose(b, s, h, got) == Reject::ok) {
      ++accepted;
      for (float a : got.dof_rad) ASSERT_LE(std::abs(a), 3.2f);
      ASSERT_NEAR(glm::length(got.root_orientation), 1.0f, 1e-3f);
    }
  }
  std::printf("  %d of 20000 damaged packets decoded (values in range)\n", accepted);
  // The sane state survives: the next real frame still applies.
  enc.update(pose_packet({4, 0, 12, 0}, frames[11]));
  ASSERT_EQ(decode_lean_pose(delta, rx, h, got), Reject::ok);
  ASSERT_EQ(decode_lean_pose(enc.delta(), rx, h, got), Reject::ok);
}

TEST(PoseStream, LargeSkeletonsStayOnPoseFrames) {
  rig::Pose p;
  p.dof_rad.assign(kMaxLeanPoseDofs + 1, 0.1f);
  LeanPoseEncoder enc;
  EXPECT_FALSE(enc.update(pose_packet({1, 0, 1, 0}, p)));
  p.dof_rad.assign(kMaxLeanPoseDofs, 3.1f);
  ASSERT_TRUE(enc.update(pose_packet({1, 0, 1, 0}, p)));
  EXPECT_LE(enc.key().size(), kMaxDatagramBytes);
  EXPECT_FALSE(enc.key().empty());
}

}  // namespace
}  // namespace mimic::net::pose_stream_test
