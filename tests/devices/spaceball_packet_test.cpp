#include "mimic/devices/spaceball_packet.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace spaceball_packet_test {

namespace sb = mimic::devices::spaceball;
using Bytes = std::vector<uint8_t>;

namespace {

// Feeds `bytes` through a framer and returns every clean packet.
std::vector<Bytes> frame_all(sb::Framer& f, const Bytes& bytes) {
  std::vector<Bytes> out;
  for (uint8_t b : bytes) {
    if (f.push(b)) out.emplace_back(f.packet().begin(), f.packet().end());
  }
  return out;
}

Bytes encode(std::span<const uint8_t> body) {
  Bytes out(body.size() * 2 + 1);
  out.resize(sb::encode_packet(body, out));
  return out;
}

Bytes text(const std::string& s) { return Bytes(s.begin(), s.end()); }

}  // namespace

TEST(SpaceballPacket, WorkedDisplacementFromProtocolDoc) {
  // device-protocols.md §2.5: period 16, TX=100, TY=-100, TZ=256, RZ=1.
  const Bytes wire = {0x44, 0x00, 0x10, 0x00, 0x64, 0xFF, 0x9C, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x0D};
  const auto body = sb::displacement_body(16, {100, -100, 256, 0, 0, 1});
  EXPECT_EQ(encode(body), wire);

  sb::Framer f;
  auto packets = frame_all(f, wire);
  ASSERT_EQ(packets.size(), 1u);
  const auto p = sb::decode(packets[0]);
  EXPECT_EQ(p.kind, sb::PacketKind::displacement);
  EXPECT_EQ(p.period_16th_ms, 16);
  EXPECT_EQ(p.axes, (sb::Axes{100, -100, 256, 0, 0, 1}));
}

TEST(SpaceballPacket, WorkedEscapedDisplacementFromProtocolDoc) {
  // TX = 0D11h, TY = 135Eh, RZ = -1. The doc's example shows eight zero bytes between TY and
  // RZ, one word too many for a 15-byte D packet; TZ, RX and RY take six.
  const Bytes wire = {0x44, 0x00, 0x10, 0x5E, 0x4D, 0x5E, 0x51, 0x5E, 0x53, 0x5E,
                      0x5E, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xFF, 0xFF, 0x0D};
  const auto body = sb::displacement_body(16, {0x0D11, 0x135E, 0, 0, 0, -1});
  EXPECT_EQ(encode(body), wire);
  sb::Framer f;
  auto packets = frame_all(f, wire);
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(sb::decode(packets[0]).axes, (sb::Axes{0x0D11, 0x135E, 0, 0, 0, -1}));
}

TEST(SpaceballPacket, PowerUpBannerWithXonAndCrLf) {
  Bytes wire = {0x11, 0x0D};
  for (auto s : {std::string("@1 Spaceball alive and well after a poweron reset.\r\n"),
                 std::string("@2 Firmware version 2.63 created on 11-Jan-1994.\r")}) {
    auto t = text(s);
    wire.insert(wire.end(), t.begin(), t.end());
  }
  sb::Framer f;
  auto packets = frame_all(f, wire);
  ASSERT_EQ(packets.size(), 2u);
  const auto p1 = sb::decode(packets[0]);
  EXPECT_EQ(p1.kind, sb::PacketKind::banner);
  EXPECT_TRUE(p1.banner_reset);
  const auto p2 = sb::decode(packets[1]);
  EXPECT_FALSE(p2.banner_reset);
  EXPECT_EQ(p2.firmware_x100, 263);
  EXPECT_EQ(p2.model, sb::Model::sb3003);
  EXPECT_EQ(f.dropped(), 0u);
}

TEST(SpaceballPacket, ModelReplies) {
  EXPECT_EQ(sb::decode(text("Hm2003B")).model, sb::Model::sb2003);
  EXPECT_EQ(sb::decode(text("Hm2003C")).model, sb::Model::sb2003);
  EXPECT_EQ(sb::decode(text("Hm3003C")).model, sb::Model::sb3003);
  const auto flx = sb::decode(text("HvFirmware version 2.42 created on 24-Oct-1997"));
  EXPECT_EQ(flx.model, sb::Model::sb4000flx);
  EXPECT_EQ(flx.firmware_x100, 242);
  EXPECT_EQ(sb::decode(text("\"1 Spaceball 4000 FLX")).model, sb::Model::sb4000flx);
  EXPECT_FALSE(sb::decode(text("\"2 B:12 L PnP:p Az:a Sns:S")).right_handed);
  EXPECT_TRUE(sb::decode(text("\"2 B:12 R PnP:p Az:a Sns:S")).right_handed);
  EXPECT_EQ(sb::decode(text("?xyz")).kind, sb::PacketKind::bad_command);
  EXPECT_EQ(sb::decode(text("MSSV")).kind, sb::PacketKind::echo);
}

TEST(SpaceballPacket, FirmwareModelTable) {
  EXPECT_EQ(sb::model_from_firmware(263), sb::Model::sb3003);
  EXPECT_EQ(sb::model_from_firmware(245), sb::Model::sb4000flx);
  EXPECT_EQ(sb::model_from_firmware(215), sb::Model::sb2003);
  EXPECT_EQ(sb::model_from_firmware(999), sb::Model::unknown);
}

TEST(SpaceballPacket, KeyBitsFollowTheDocumentedLayout) {
  // 2003: b2 bits 0–3 = buttons 1–4, b1 bits 0–2 = 5–7, b1 bit 3 = rezero, bit 4 = pick.
  EXPECT_EQ(sb::decode(Bytes{'K', 0x00, 0x01}).buttons, 1u << 0);
  EXPECT_EQ(sb::decode(Bytes{'K', 0x04, 0x00}).buttons, 1u << 6);
  EXPECT_EQ(sb::decode(Bytes{'K', 0x08, 0x00}).buttons, 1u << 7);
  EXPECT_EQ(sb::decode(Bytes{'K', 0x10, 0x00}).buttons, 1u << 8);
  // 3003: left/right in b2 bits 4/5 fold onto buttons 1/2; rezero in b1 bit 5.
  EXPECT_EQ(sb::decode(Bytes{'K', 0x00, 0x30}).buttons, 0x3u);
  EXPECT_EQ(sb::decode(Bytes{'K', 0x20, 0x00}).buttons, 1u << 7);
  // Bit 6 is ignored (printable button bytes).
  EXPECT_EQ(sb::decode(Bytes{'K', 0x40, 0x41}).buttons, 1u);
  // 4000 FLX '.': b2 bits 0–5 = 1–6, b2 bit 7 = 7, b1 bits 0–4 = 8–12, b1 bit 5 = right-handed.
  const auto dot = sb::decode(Bytes{'.', 0x21, 0x80});
  EXPECT_EQ(dot.kind, sb::PacketKind::advanced_keys);
  EXPECT_EQ(dot.buttons, (1u << 6) | (1u << 7));
  EXPECT_TRUE(dot.right_handed);
  EXPECT_FALSE(sb::decode(Bytes{'.', 0x00, 0x00}).right_handed);
}

TEST(SpaceballPacket, WrongLengthsDecodeAsNone) {
  EXPECT_EQ(sb::decode(Bytes{'D', 0, 1, 2}).kind, sb::PacketKind::none);
  EXPECT_EQ(sb::decode(Bytes{'K', 0}).kind, sb::PacketKind::none);
  EXPECT_EQ(sb::decode(Bytes{'.', 0, 0, 0}).kind, sb::PacketKind::none);
  EXPECT_EQ(sb::decode(Bytes{}).kind, sb::PacketKind::none);
}

TEST(SpaceballPacket, ErrorPackets) {
  EXPECT_EQ(sb::decode(text("E@B")).error_bits, (1u << 0) | (1u << 2));
  EXPECT_EQ(sb::decode(Bytes{'E', 0x04, 0x00}).error_bits, 0x0400u);
}

TEST(SpaceballPacket, BadEscapeDropsOnlyThatPacket) {
  sb::Framer f;
  Bytes wire = {'K', 0x5E, 'X', 0x00, 0x0D};  // ^X is not a valid escape
  auto more = encode(sb::keys_body(sb::Model::sb2003, 0x5, false));
  wire.insert(wire.end(), more.begin(), more.end());
  auto packets = frame_all(f, wire);
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(sb::decode(packets[0]).buttons, 0x5u);
  EXPECT_EQ(f.dropped(), 1u);
}

TEST(SpaceballPacket, DanglingCaretBeforeCrDropsPacket) {
  sb::Framer f;
  auto packets = frame_all(f, Bytes{'K', 0x40, 0x5E, 0x0D});
  EXPECT_TRUE(packets.empty());
  EXPECT_EQ(f.dropped(), 1u);
}

TEST(SpaceballPacket, OverlongGarbageIsDroppedAndFramingRecovers) {
  sb::Framer f;
  Bytes wire(500, 'x');
  auto good = encode(sb::displacement_body(32, {1, 2, 3, 4, 5, 6}));
  wire.push_back(0x0D);
  wire.insert(wire.end(), good.begin(), good.end());
  auto packets = frame_all(f, wire);
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(sb::decode(packets[0]).axes, (sb::Axes{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(f.dropped(), 1u);
}

TEST(SpaceballPacket, TornPacketAcrossFeedsDecodesWhole) {
  // Bytes arrive in arbitrary chunks; the framer has no notion of reads.
  std::mt19937_64 rng(7);
  const auto wire = encode(sb::displacement_body(0x0D5E, {0x1311, -1, 0x5E5E, 0x0D0D, 13, 94}));
  sb::Framer f;
  size_t got = 0;
  for (int rep = 0; rep < 50; ++rep) {
    size_t i = 0;
    while (i < wire.size()) {
      const size_t n = 1 + rng() % 4;
      for (size_t k = 0; k < n && i < wire.size(); ++k, ++i) {
        if (f.push(wire[i])) {
          EXPECT_EQ(sb::decode(f.packet()).axes, (sb::Axes{0x1311, -1, 0x5E5E, 0x0D0D, 13, 94}));
          EXPECT_EQ(sb::decode(f.packet()).period_16th_ms, 0x0D5E);
          ++got;
        }
      }
    }
  }
  EXPECT_EQ(got, 50u);
}

TEST(SpaceballPacket, DisplacementRoundTripProperty) {
  std::mt19937_64 rng(12345);
  sb::Framer f;
  for (int i = 0; i < 5000; ++i) {
    sb::Axes axes;
    for (auto& a : axes) {
      // Bias towards the escaped byte values so every escape path is exercised often.
      static constexpr uint8_t special[] = {0x0D, 0x11, 0x13, 0x5E, 0x00, 0xFF};
      const uint8_t hi = (rng() & 1) ? special[rng() % 6] : static_cast<uint8_t>(rng());
      const uint8_t lo = (rng() & 1) ? special[rng() % 6] : static_cast<uint8_t>(rng());
      a = static_cast<int16_t>((hi << 8) | lo);
    }
    const auto period = static_cast<uint16_t>(rng());
    const auto wire = encode(sb::displacement_body(period, axes));
    for (size_t k = 0; k + 1 < wire.size(); ++k) {
      ASSERT_NE(wire[k], 0x0D);
      ASSERT_NE(wire[k], 0x11);
      ASSERT_NE(wire[k], 0x13);
    }
    auto packets = frame_all(f, wire);
    ASSERT_EQ(packets.size(), 1u);
    const auto p = sb::decode(packets[0]);
    ASSERT_EQ(p.axes, axes);
    ASSERT_EQ(p.period_16th_ms, period);
  }
  EXPECT_EQ(f.dropped(), 0u);
}

TEST(SpaceballPacket, KeysRoundTripPerModel) {
  std::mt19937_64 rng(99);
  for (int i = 0; i < 2000; ++i) {
    const auto buttons = static_cast<uint32_t>(rng());
    const bool printable = rng() & 1;
    // 2003: buttons 1–9.
    EXPECT_EQ(sb::decode(sb::keys_body(sb::Model::sb2003, buttons, printable)).buttons, buttons & 0x1FFu);
    // 3003: left, right and rezero (button 8).
    EXPECT_EQ(sb::decode(sb::keys_body(sb::Model::sb3003, buttons, printable)).buttons, buttons & 0x83u);
    // 4000 FLX: K carries buttons 1–8; '.' carries 1–12 and handedness.
    EXPECT_EQ(sb::decode(sb::keys_body(sb::Model::sb4000flx, buttons, printable)).buttons, buttons & 0xFFu);
    const bool right = rng() & 1;
    const auto dot = sb::decode(sb::advanced_keys_body(buttons, right, printable));
    EXPECT_EQ(dot.buttons, buttons & 0xFFFu);
    EXPECT_EQ(dot.right_handed, right);
  }
}

TEST(SpaceballPacket, FrameMappingRoundTripAndConventions) {
  sb::Scaling s;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    mimic::devices::InputFrame in;
    in.translation = {u(rng), u(rng), u(rng)};
    in.rotation = {u(rng), u(rng), u(rng)};
    mimic::devices::InputFrame out;
    sb::to_frame(sb::from_frame(in, s), s, out);
    for (int k = 0; k < 3; ++k) {
      const float tq = 1.0f / s.translation_full_scale, rq = 1.0f / s.rotation_full_scale;
      const float nr = static_cast<float>(s.null_radius) + 0.5f;
      if (std::abs(in.translation[k]) > nr * tq) {
        EXPECT_NEAR(out.translation[k], in.translation[k], tq);
      }
      if (std::abs(in.rotation[k]) > nr * rq) {
        EXPECT_NEAR(out.rotation[k], in.rotation[k], rq);
      }
    }
  }
  // +TZ on the wire points away from the user; the frame's +Z points toward the user.
  mimic::devices::InputFrame f;
  sb::to_frame({0, 4000, 4000, 0, 0, 800}, s, f);
  EXPECT_FLOAT_EQ(f.translation.y, 0.5f);
  EXPECT_FLOAT_EQ(f.translation.z, -0.5f);
  EXPECT_FLOAT_EQ(f.rotation.z, -0.5f);
  // Null radius and clamping.
  sb::to_frame({8, -8, 9, 32767, -32768, 0}, s, f);
  EXPECT_EQ(f.translation.x, 0.0f);
  EXPECT_EQ(f.translation.y, 0.0f);
  EXPECT_GT(f.translation.z, -0.01f);
  EXPECT_FLOAT_EQ(f.rotation.x, 1.0f);
  EXPECT_FLOAT_EQ(f.rotation.y, -1.0f);
}

}  // namespace spaceball_packet_test
