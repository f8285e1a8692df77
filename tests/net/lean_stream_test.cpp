// The lean pose stream through a real server over loopback: old and lean subscribers side by
// side, the server's reference rule under latest-wins drops, and key frames on request.
#include <gtest/gtest.h>

#include <cmath>

#include "mimic/rig/motion.h"
#include "mimic/net/pose_stream.h"
#include "net_test_support.h"

namespace mimic::net::lean_stream_test {
namespace {

using namespace test;

std::unique_ptr<Client> connect(const ServerThread& st, Role role, bool lean) {
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = role;
  o.lean = lean;
  auto c = Client::connect(o);
  EXPECT_TRUE(c) << c.error().what();
  return c ? std::move(*c) : nullptr;
}

Bytes lean_hello() {
  Hello h;
  h.role = Role::subscriber;
  h.name = "raw";
  h.capabilities = kCapPose | kCapLeanPose;
  Bytes b(kMaxHelloBytes);
  b.resize(encode_hello(h, b));
  return b;
}

struct Walk {
  rig::Skeleton skeleton;
  std::unique_ptr<rig::Motion> motion;
  static Walk make() {
    auto s = rig::Skeleton::build(rig::default_skeleton_desc());
    EXPECT_TRUE(s);
    auto m = rig::make_builtin_motion("walk", *s);
    EXPECT_TRUE(m);
    return {*s, std::move(*m)};
  }
  rig::Pose at(uint32_t seq) const {
    rig::Pose p = skeleton.zero_pose();
    motion->sample(seq / 90.0, p);
    return p;
  }
};

TEST(LeanStream, OldAndLeanSubscribersGetEveryFrameLeanOnesInAThirdOfTheBytes) {
  ServerThread st;
  const Walk walk = Walk::make();
  const uint16_t dofs = uint16_t(walk.skeleton.dof_count());
  auto old_sub = connect(st, Role::subscriber, false);
  auto lean_sub = connect(st, Role::subscriber, true);
  auto pub = connect(st, Role::publisher, false);
  ASSERT_TRUE(old_sub && lean_sub && pub);
  EXPECT_EQ(old_sub->negotiated_capabilities() & kCapLeanPose, 0u);
  EXPECT_NE(lean_sub->negotiated_capabilities() & kCapLeanPose, 0u);
  auto slot = pub->add_avatar("walker", dofs, "m");
  ASSERT_TRUE(slot);
  ASSERT_TRUE(pump({old_sub.get(), lean_sub.get(), pub.get()},
                   [&] { return old_sub->avatars().size() == 1 && lean_sub->avatars().size() == 1; }));
  const uint32_t n = 200;
  for (uint32_t s = 1; s <= n; ++s) {
    const uint64_t before_old = old_sub->stats().frames, before_lean = lean_sub->stats().frames;
    ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, s, wall_clock_us()}, walk.at(s)));
    ASSERT_TRUE(pump({old_sub.get(), lean_sub.get(), pub.get()}, [&] {
      return old_sub->stats().frames > before_old && lean_sub->stats().frames > before_lean;
    })) << s;
    const auto& a = lean_sub->avatars().begin()->second;
    ASSERT_EQ(a.last.sequence, s);
    // Within the documented bound of the pose the publisher sent.
    const rig::Pose want = walk.at(s);
    const double bound = (double(1u << kDefaultPoseShift) + 1.0) / 2.0 * kAngleStep_rad + 1e-6;
    for (size_t i = 0; i < want.dof_rad.size(); ++i)
      ASSERT_LE(std::abs(std::remainder(double(a.pose.dof_rad[i]) - double(want.dof_rad[i]), 2 * M_PI)), bound) << s;
  }
  EXPECT_EQ(old_sub->stats().frames, n);
  EXPECT_EQ(lean_sub->stats().frames, n);
  EXPECT_EQ(old_sub->stats().lost + lean_sub->stats().lost, 0u);
  EXPECT_EQ(old_sub->stats().frame_bytes, n * pose_packet_bytes(dofs));
  // A key on joining the stream and at sequences 90 and 180; deltas otherwise.
  EXPECT_EQ(lean_sub->stats().lean_keys, 3u);
  EXPECT_EQ(lean_sub->stats().lean_unreferenced, 0u);
  const double lean_bytes = double(lean_sub->stats().frame_bytes) / n;
  std::printf("  walk: %.1f bytes per avatar-frame on the lean stream, %zu as POSE\n", lean_bytes,
              pose_packet_bytes(dofs));
  EXPECT_LT(lean_bytes, double(pose_packet_bytes(dofs)) / 2);
  const auto stats = st.stats();
  EXPECT_EQ(stats.lean_keys_out, 3u);
  EXPECT_EQ(stats.lean_deltas_out, n - 3);
}

// A stalled subscriber has frames dropped for it; whatever reaches it must decode: the server
// never sends a delta whose reference the subscriber was not sent.
TEST(LeanStream, StalledSubscriberNeverGetsADeltaWithoutItsReference) {
  ServerOptions opt;
  opt.send_buffer_bytes = 4096;
  ServerThread st(opt);
  const Walk walk = Walk::make();
  const uint16_t dofs = uint16_t(walk.skeleton.dof_count());
  RawPeer stalled(st.port(), 2048);
  ASSERT_TRUE(stalled.send(lean_hello()));  // ... and does not read for a while
  auto pub = connect(st, Role::publisher, false);
  auto slot = pub->add_avatar("walker", dofs, "m");
  ASSERT_TRUE(slot);
  pump_for({pub.get()}, 0.1);
  const uint32_t n = 600;
  for (uint32_t s = 1; s <= n; ++s) {
    ASSERT_TRUE(pub->publish_pose(*slot, {0, 0, s, wall_clock_us()}, walk.at(s)));
    pump_for({pub.get()}, 0.0005);
  }
  ASSERT_TRUE(pump({pub.get()}, [&] { return st.stats().frames_in == n; }));
  PacketReader r;
  feed(r, stalled.read_until_quiet(0.3));
  LeanPoseState state;
  rig::Pose pose;
  PoseHeader h;
  uint32_t frames = 0, keys = 0, last_seq = 0;
  for (;;) {
    std::span<const uint8_t> p;
    ASSERT_EQ(r.next(p), Reject::ok);
    if (p.empty()) break;
    ASSERT_NE(p[2], uint8_t(MsgType::pose));  // it asked for the lean stream
    if (p[2] != uint8_t(MsgType::pose_delta)) continue;
    ASSERT_EQ(decode_lean_pose(p, state, h, pose), Reject::ok) << "frame " << lean_pose_sequence(p);
    frames++;
    keys += lean_pose_is_key(p);
    last_seq = h.sequence;
  }
  EXPECT_EQ(last_seq, n);
  EXPECT_LT(frames, n);  // frames were dropped for it...
  EXPECT_GT(keys, 1u);   // ... and every gap was bridged by a key frame
  std::printf("  stalled subscriber: %u of %u frames, %u key frames\n", frames, n, keys);
}

TEST(LeanStream, KeyRequestMakesTheNextFrameAKey) {
  ServerThread st;
  RawPeer raw(st.port());
  ASSERT_TRUE(raw.send(lean_hello()));
  auto pub = connect(st, Role::publisher, false);
  auto slot = pub->add_avatar("walker", 10, "m");
  ASSERT_TRUE(slot);
  uint16_t avatar_id = 0;
  PacketReader reader;
  auto next_frame = [&](uint32_t seq) -> Bytes {
    rig::Pose p;
    p.dof_rad.assign(10, 0.01f * float(seq));
    EXPECT_TRUE(pub->publish_pose(*slot, {0, 0, seq, wall_clock_us()}, p));
    for (int tries = 0; tries < 50; ++tries) {
      pump_for({pub.get()}, 0.002);
      const Bytes got = raw.read(0.05, 1);
      auto space = reader.write_space(got.size());
      std::copy(got.begin(), got.end(), space.begin());
      reader.commit(got.size());
      for (;;) {
        std::span<const uint8_t> pk;
        if (reader.next(pk) != Reject::ok || pk.empty()) break;
        const Bytes b(pk.begin(), pk.end());
        if (b[2] == uint8_t(MsgType::avatar_model)) {
          AvatarModel m;
          EXPECT_EQ(decode_avatar_model(b, m), Reject::ok);
          avatar_id = m.avatar;
        }
        if (b[2] == uint8_t(MsgType::pose_delta)) return b;
      }
    }
    return {};
  };
  const Bytes f1 = next_frame(1), f2 = next_frame(2), f3 = next_frame(3);
  ASSERT_FALSE(f1.empty() || f2.empty() || f3.empty());
  EXPECT_TRUE(lean_pose_is_key(f1));
  EXPECT_FALSE(lean_pose_is_key(f2));
  EXPECT_FALSE(lean_pose_is_key(f3));
  Bytes req(16);
  req.resize(encode_key_request(avatar_id, req));
  ASSERT_TRUE(raw.send(req));
  ASSERT_TRUE(pump({pub.get()}, [&] { return st.stats().key_requests == 1; }));
  const Bytes f4 = next_frame(4), f5 = next_frame(5);
  EXPECT_TRUE(lean_pose_is_key(f4));
  EXPECT_EQ(lean_pose_sequence(f4), 4u);
  EXPECT_FALSE(lean_pose_is_key(f5));
}

// Over UDP a lean subscriber gets one datagram per tick holding every avatar's frame.
TEST(LeanStream, UdpDatagramsCarryEveryAvatarOfATick) {
  ServerThread st;
  const Walk walk = Walk::make();
  const uint16_t dofs = uint16_t(walk.skeleton.dof_count());
  std::vector<uint16_t> ids;
  for (int i = 0; i < 5; ++i)
    ids.push_back(st.call([&] { return *st.server().add_avatar("w" + std::to_string(i), dofs, "m"); }));
  ClientOptions o;
  o.connect = st.endpoint();
  o.udp = true;
  o.lean = true;
  auto c = Client::connect(o);
  ASSERT_TRUE(c);
  Client& sub = **c;
  ASSERT_TRUE(pump({&sub}, [&] { return sub.udp_active() && sub.avatars().size() == ids.size(); }));
  const uint32_t ticks = 60;
  const auto calls_before = st.stats().udp_send_calls;
  for (uint32_t k = 1; k <= ticks; ++k) {
    st.call([&] {
      std::vector<uint8_t> packet(pose_packet_bytes(dofs));
      st.server().begin_batch();
      for (size_t i = 0; i < ids.size(); ++i) {
        encode_pose({ids[i], 0, k, wall_clock_us()}, walk.at(k + 40 * uint32_t(i)), packet);
        st.server().publish_pose(ids[i], packet);
      }
      st.server().end_batch();
    });
    ASSERT_TRUE(pump({&sub}, [&] { return sub.stats().udp_frames >= uint64_t(k) * ids.size(); })) << k;
  }
  EXPECT_EQ(sub.stats().udp_frames, ticks * ids.size());
  EXPECT_EQ(sub.stats().lost, 0u);
  EXPECT_EQ(sub.stats().lean_unreferenced, 0u);
  EXPECT_EQ(st.stats().udp_send_calls - calls_before, ticks);  // one sendmmsg per tick...
  EXPECT_EQ(st.stats().udp_frames_out, ticks * ids.size());    // ... of one datagram with 5 frames
  for (const auto& [id, a] : sub.avatars()) EXPECT_EQ(a.last.sequence, ticks) << id;
}

}  // namespace
}  // namespace mimic::net::lean_stream_test
