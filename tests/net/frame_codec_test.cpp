#include <gtest/gtest.h>

#include <random>

#include "mimic/net/frame_codec.h"

namespace mimic::net::frame_codec_test {
namespace {

using Bytes = std::vector<uint8_t>;

rig::Pose random_pose(std::mt19937_64& rng, size_t dofs) {
  std::uniform_real_distribution<float> angle(-3.14159f, 3.14159f), pos(-100.0f, 100.0f), unit(-1, 1);
  rig::Pose p;
  p.root_position_m = {pos(rng), pos(rng), pos(rng)};
  glm::quat q(unit(rng), unit(rng), unit(rng), unit(rng));
  if (glm::length(q) < 1e-3f) q = glm::quat(1, 0, 0, 0);
  p.root_orientation = glm::normalize(q);
  p.dof_rad.resize(dofs);
  for (auto& a : p.dof_rad) a = angle(rng);
  return p;
}

Bytes pose_packet(const PoseHeader& h, const rig::Pose& p) {
  Bytes b(kMaxDatagramBytes);
  b.resize(encode_pose(h, p, b));
  return b;
}

// Same rotation (q and -q), within quantisation.
float rotation_distance(glm::quat a, glm::quat b) { return 1.0f - std::abs(glm::dot(a, b)); }

TEST(FrameCodec, DefaultSkeletonPoseFitsTheBudget) {
  auto s = rig::Skeleton::build(rig::default_skeleton_desc());
  ASSERT_TRUE(s);
  const Bytes b = pose_packet({}, s->rest_pose());
  EXPECT_EQ(b.size(), pose_packet_bytes(s->dof_count()));
  EXPECT_LE(b.size(), 200u);
  EXPECT_LE(pose_packet_bytes(kMaxPoseDofs), kMaxDatagramBytes);
}

TEST(FrameCodec, PoseRoundTripProperty) {
  std::mt19937_64 rng(7);
  rig::Pose decoded;
  for (int trial = 0; trial < 2000; ++trial) {
    const size_t n = rng() % (kMaxPoseDofs + 1);
    const rig::Pose p = random_pose(rng, n);
    PoseHeader h{uint16_t(rng()), uint16_t(rng() & 1), uint32_t(rng()), rng()};
    const Bytes b = pose_packet(h, p);
    ASSERT_EQ(b.size(), pose_packet_bytes(n));
    PoseHeader dh;
    ASSERT_EQ(decode_pose(b, dh, decoded), Reject::ok);
    EXPECT_EQ(dh.avatar, h.avatar);
    EXPECT_EQ(dh.flags, h.flags);
    EXPECT_EQ(dh.sequence, h.sequence);
    EXPECT_EQ(dh.time_us, h.time_us);
    ASSERT_EQ(decoded.dof_rad.size(), n);
    for (size_t i = 0; i < n; ++i) ASSERT_NEAR(decoded.dof_rad[i], p.dof_rad[i], kAngleStep_rad) << i;
    for (int a = 0; a < 3; ++a) ASSERT_NEAR(decoded.root_position_m[a], p.root_position_m[a], 2e-5f);
    ASSERT_LT(rotation_distance(decoded.root_orientation, p.root_orientation), 1e-6f);
    // Re-encoding the decoded pose keeps the header and the DOF bytes exactly: joint
    // quantisation is idempotent, so relaying a frame does not drift it.
    const Bytes again = pose_packet(dh, decoded);
    ASSERT_EQ(again.size(), b.size());
    ASSERT_TRUE(std::equal(b.begin(), b.begin() + 24, again.begin()));
    ASSERT_TRUE(std::equal(b.begin() + long(kPoseFixedBytes) - 2, b.end(), again.begin() + long(kPoseFixedBytes) - 2));
  }
}

TEST(FrameCodec, AnglesWrapIntoPlusMinusPi) {
  rig::Pose p;
  p.dof_rad = {3.0f * 3.14159265f, -7.0f, 0.5f + 2 * 3.14159265f, std::nanf("")};
  const Bytes b = pose_packet({}, p);
  PoseHeader h;
  rig::Pose d;
  ASSERT_EQ(decode_pose(b, h, d), Reject::ok);
  EXPECT_NEAR(std::abs(d.dof_rad[0]), 3.14159265f, 2 * kAngleStep_rad);
  EXPECT_NEAR(d.dof_rad[1], -7.0f + 2 * 3.14159265f, 2 * kAngleStep_rad);
  EXPECT_NEAR(d.dof_rad[2], 0.5f, 2 * kAngleStep_rad);
  EXPECT_EQ(d.dof_rad[3], 0.0f);
}

TEST(FrameCodec, TooManyDofsIsNotEncoded) {
  rig::Pose p;
  p.dof_rad.resize(kMaxPoseDofs + 1);
  Bytes b(4096);
  EXPECT_EQ(encode_pose({}, p, b), 0u);
}

TEST(FrameCodec, EncoderRefusesSmallBuffers) {
  rig::Pose p;
  p.dof_rad.resize(10);
  Bytes b(pose_packet_bytes(10) - 1);
  EXPECT_EQ(encode_pose({}, p, b), 0u);
}

template <class Msg, class Enc, class Dec>
Bytes round_trip(const Msg& m, Enc enc, Dec dec, Msg& out) {
  Bytes b(kMaxPacketBytes);
  b.resize(enc(m, std::span<uint8_t>(b)));
  EXPECT_GT(b.size(), 0u);
  EXPECT_EQ(dec(std::span<const uint8_t>(b), out), Reject::ok);
  return b;
}

TEST(FrameCodec, HandshakeRoundTrips) {
  Hello h;
  h.min_version = 1;
  h.max_version = 3;
  h.role = Role::publisher;
  h.mesh_lod = 2;
  h.capabilities = kCapPose | kCapMesh;
  for (uint8_t i = 0; i < kTokenBytes; ++i) h.resume_token.bytes[i] = uint8_t(0x11 * (i + 1));
  h.name = "studio-a";
  h.secret = "s3cret";
  Hello hd;
  round_trip(h, encode_hello, decode_hello, hd);
  EXPECT_EQ(hd.max_version, 3);
  EXPECT_EQ(hd.role, Role::publisher);
  EXPECT_EQ(hd.mesh_lod, 2);
  EXPECT_EQ(hd.capabilities, h.capabilities);
  EXPECT_EQ(hd.resume_token, h.resume_token);
  EXPECT_EQ(hd.name, h.name);
  EXPECT_EQ(hd.secret, h.secret);

  SessionToken t;
  t.bytes[15] = 42;
  Welcome w{2, kCapPose | kCapResume, t, 7, true}, wd;
  round_trip(w, encode_welcome, decode_welcome, wd);
  EXPECT_EQ(wd.capabilities, w.capabilities);
  EXPECT_EQ(wd.session_token, t);
  EXPECT_EQ(wd.client_id, 7u);
  EXPECT_TRUE(wd.resumed);

  RejectMsg r{Reject::unauthorized, 1, 1, "no"}, rd;
  round_trip(r, encode_reject, decode_reject, rd);
  EXPECT_EQ(rd.reason, Reject::unauthorized);
  EXPECT_EQ(rd.message, "no");
}

TEST(FrameCodec, ModelAndMeshRoundTrip) {
  AvatarModel m{3, 9, 52, "alice", std::string("\0\1\2binary body", 14)}, md;
  const Bytes mb = round_trip(m, encode_avatar_model, decode_avatar_model, md);
  EXPECT_EQ(mb.size(), avatar_model_packet_bytes(m));
  EXPECT_EQ(md.avatar, 3);
  EXPECT_EQ(md.revision, 9u);
  EXPECT_EQ(md.dof_count, 52);
  EXPECT_EQ(md.name, "alice");
  EXPECT_EQ(md.model_bytes, m.model_bytes);

  MeshTopology t{4, 1, 5, {0, 1, 2, 2, 3, 4}}, td;
  round_trip(t, encode_mesh_topology, decode_mesh_topology, td);
  EXPECT_EQ(td.indices, t.indices);
  EXPECT_EQ(td.vertex_count, 5u);

  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<glm::vec3> pos(500);
  for (auto& p : pos) p = {u(rng) * 0.4f, u(rng) + 1.0f, u(rng) * 0.2f};
  Bytes b(mesh_packet_bytes(pos.size()));
  ASSERT_EQ(encode_mesh({4, 1, 77, 1234}, pos, b), b.size());
  MeshFrameHeader h;
  std::vector<glm::vec3> out;
  ASSERT_EQ(decode_mesh(b, h, out), Reject::ok);
  EXPECT_EQ(h.sequence, 77u);
  ASSERT_EQ(out.size(), pos.size());
  for (size_t i = 0; i < pos.size(); ++i)
    for (int a = 0; a < 3; ++a) ASSERT_NEAR(out[i][a], pos[i][a], 2.0f / 65535.0f);
}

TEST(FrameCodec, SceneRoundTrips) {
  std::vector<SceneEntry> in = {{1, 7}, {5, 9}, {4096, 123456}}, out;
  Bytes b(scene_packet_bytes(in.size()));
  ASSERT_EQ(encode_scene(in, b), b.size());
  ASSERT_EQ(decode_scene(b, out), Reject::ok);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[2].avatar, 4096);
  EXPECT_EQ(out[2].revision, 123456u);
  for (size_t n = 0; n < b.size(); ++n) EXPECT_NE(decode_scene(std::span<const uint8_t>(b).first(n), out), Reject::ok);
}

TEST(FrameCodec, TopologyWithIndexOutOfRangeIsMalformed) {
  MeshTopology t{4, 1, 3, {0, 1, 3}};
  Bytes b(256);
  b.resize(encode_mesh_topology(t, b));
  MeshTopology d;
  EXPECT_EQ(decode_mesh_topology(b, d), Reject::malformed);
}

// Every strict prefix of a valid packet is refused; so is any extra trailing byte.
TEST(FrameCodec, TruncatedAndPaddedPacketsAreRefused) {
  std::mt19937_64 rng(11);
  const Bytes pose = pose_packet({1, 0, 5, 6}, random_pose(rng, 52));
  for (size_t n = 0; n < pose.size(); ++n) {
    PoseHeader h;
    rig::Pose d;
    EXPECT_NE(decode_pose(std::span<const uint8_t>(pose).first(n), h, d), Reject::ok) << n;
  }
  // A header that claims fewer DOFs than the bytes carry: length and count disagree.
  Bytes lying = pose;
  lying[kPoseFixedBytes - 2] = 51;
  PoseHeader h;
  rig::Pose d;
  EXPECT_EQ(decode_pose(lying, h, d), Reject::malformed);
  lying[kPoseFixedBytes - 2] = 60;
  EXPECT_EQ(decode_pose(lying, h, d), Reject::truncated);

  Hello hello;
  hello.name = "x";
  Bytes hb(kMaxHelloBytes);
  hb.resize(encode_hello(hello, hb));
  for (size_t n = 0; n < hb.size(); ++n) {
    Hello o;
    EXPECT_NE(decode_hello(std::span<const uint8_t>(hb).first(n), o), Reject::ok) << n;
  }
  Bytes padded = hb;
  padded.push_back(0);
  padded[4]++;  // payload length includes the extra byte
  Hello o;
  EXPECT_EQ(decode_hello(padded, o), Reject::malformed);
}

TEST(FrameCodec, HeaderChecks) {
  const Bytes pose = pose_packet({}, rig::Pose{});
  Header h;
  EXPECT_EQ(decode_header(pose, h), Reject::ok);
  Bytes b = pose;
  b[0] = 'X';
  EXPECT_EQ(decode_header(b, h), Reject::bad_magic);
  b = pose;
  b[1] = 3;
  EXPECT_EQ(decode_header(b, h), Reject::unknown_version);
  b[1] = 1;  // version 1 (64-bit tokens) is no longer spoken
  EXPECT_EQ(decode_header(b, h), Reject::unknown_version);
  b[1] = 0;
  EXPECT_EQ(decode_header(b, h), Reject::unknown_version);
  b = pose;
  b[2] = 99;
  EXPECT_EQ(decode_header(b, h), Reject::unknown_type);
  b = pose;
  b[5] = 0x10;  // 4 KB pose frame: more than one datagram
  EXPECT_EQ(decode_header(b, h), Reject::oversized);
  EXPECT_EQ(decode_header(std::span<const uint8_t>(pose).first(7), h), Reject::truncated);
}

TEST(FrameCodec, BadQuaternionAndRoleAreMalformed) {
  Bytes pose = pose_packet({}, rig::Pose{});
  for (size_t i = 0; i < 8; ++i) pose[kHeaderBytes + 28 + i] = 0;  // all-zero root quaternion
  PoseHeader h;
  rig::Pose d;
  EXPECT_EQ(decode_pose(pose, h, d), Reject::malformed);

  Hello hello;
  Bytes hb(kMaxHelloBytes);
  hb.resize(encode_hello(hello, hb));
  hb[kHeaderBytes + 2] = 9;  // role
  Hello o;
  EXPECT_EQ(decode_hello(hb, o), Reject::malformed);
}

TEST(FrameCodec, PoseDecodeDoesNotAllocateWhenSized) {
  // decode_pose resizes to the same size: capacity (and data pointer) unchanged.
  std::mt19937_64 rng(5);
  const Bytes b = pose_packet({}, random_pose(rng, 52));
  rig::Pose d;
  d.dof_rad.resize(52);
  const float* before = d.dof_rad.data();
  PoseHeader h;
  ASSERT_EQ(decode_pose(b, h, d), Reject::ok);
  EXPECT_EQ(d.dof_rad.data(), before);
}

TEST(PacketReader, SplitsAStreamAtAnyBoundary) {
  std::mt19937_64 rng(9);
  Bytes stream;
  std::vector<Bytes> packets;
  for (int i = 0; i < 20; ++i) {
    Bytes p = pose_packet({uint16_t(i), 0, uint32_t(i), 0}, random_pose(rng, rng() % 80));
    if (i % 5 == 0) {
      AvatarModel m{uint16_t(i), 1, 3, "m", std::string(5000 + i, 'x')};
      p.resize(avatar_model_packet_bytes(m));
      encode_avatar_model(m, p);
    }
    packets.push_back(p);
    stream.insert(stream.end(), p.begin(), p.end());
  }
  for (size_t chunk : {1u, 3u, 7u, 100u, 1500u, 100000u}) {
    PacketReader r(kMaxPacketBytes, 256);
    std::vector<Bytes> got;
    for (size_t pos = 0; pos < stream.size();) {
      const size_t n = std::min(chunk, stream.size() - pos);
      auto space = r.write_space(n);
      std::copy_n(stream.begin() + long(pos), n, space.begin());
      r.commit(n);
      pos += n;
      for (;;) {
        std::span<const uint8_t> p;
        ASSERT_EQ(r.next(p), Reject::ok);
        if (p.empty()) break;
        got.emplace_back(p.begin(), p.end());
      }
    }
    EXPECT_EQ(got, packets) << "chunk " << chunk;
    EXPECT_EQ(r.buffered_bytes(), 0u);
  }
}

TEST(PacketReader, RefusesOversizedBeforeBuffering) {
  PacketReader r(kMaxHelloBytes);
  AvatarModel m{1, 1, 3, "m", std::string(1000, 'x')};
  Bytes p(avatar_model_packet_bytes(m));
  encode_avatar_model(m, p);
  auto space = r.write_space(16);
  std::copy_n(p.begin(), 16, space.begin());
  r.commit(16);
  std::span<const uint8_t> out;
  EXPECT_EQ(r.next(out), Reject::oversized);

  PacketReader g;
  const char junk[] = "GET / HTTP/1.1\r\n";
  auto s2 = g.write_space(sizeof junk);
  std::copy_n(junk, sizeof junk, s2.begin());
  g.commit(sizeof junk);
  EXPECT_EQ(g.next(out), Reject::bad_magic);
}

TEST(FrameCodec, RandomBytesNeverCrashDecoders) {
  std::mt19937_64 rng(13);
  const Bytes seed = pose_packet({1, 0, 1, 1}, random_pose(rng, 52));
  Hello hello;
  hello.name = "n";
  Bytes hb(kMaxHelloBytes);
  hb.resize(encode_hello(hello, hb));
  int ok = 0;
  for (int i = 0; i < 20000; ++i) {
    Bytes b = (i % 2) ? seed : hb;
    const int flips = 1 + int(rng() % 4);
    for (int f = 0; f < flips; ++f) b[rng() % b.size()] = uint8_t(rng());
    if (rng() % 4 == 0) b.resize(rng() % (b.size() + 1));
    PoseHeader ph;
    rig::Pose p;
    Hello h;
    AvatarModel m;
    MeshTopology t;
    MeshFrameHeader mh;
    std::vector<glm::vec3> pos;
    std::vector<SceneEntry> scene;
    ok += decode_scene(b, scene) == Reject::ok;
    ok += decode_pose(b, ph, p) == Reject::ok;
    ok += decode_hello(b, h) == Reject::ok;
    ok += decode_avatar_model(b, m) == Reject::ok;
    ok += decode_mesh_topology(b, t) == Reject::ok;
    ok += decode_mesh(b, mh, pos) == Reject::ok;
  }
  EXPECT_GT(ok, 0);  // mutations that keep the structure valid do decode
}

}  // namespace
}  // namespace mimic::net::frame_codec_test
