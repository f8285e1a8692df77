#include "mimic/devices/magellan_packet.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace magellan_packet_test {

namespace mg = mimic::devices::magellan;
using Bytes = std::vector<uint8_t>;

namespace {

Bytes text(const std::string& s) { return Bytes(s.begin(), s.end()); }

std::vector<Bytes> frame_all(mg::Framer& f, const Bytes& bytes) {
  std::vector<Bytes> out;
  for (uint8_t b : bytes) {
    if (f.push(b)) out.emplace_back(f.packet().begin(), f.packet().end());
  }
  return out;
}

}  // namespace

TEST(MagellanPacket, NibbleTableHasEvenParity) {
  const std::string expected = "0AB3D56GH9:K<MN?";
  for (unsigned n = 0; n < 16; ++n) {
    const char c = mg::nibble_char(n);
    EXPECT_EQ(c, expected[n]);
    EXPECT_EQ(__builtin_popcount(static_cast<unsigned>(c)) % 2, 0) << c;
    EXPECT_TRUE(mg::valid_nibble_char(static_cast<uint8_t>(c)));
  }
  int valid = 0;
  for (unsigned c = 0; c < 256; ++c) valid += mg::valid_nibble_char(static_cast<uint8_t>(c));
  EXPECT_EQ(valid, 16);
}

TEST(MagellanPacket, WorkedExamplesFromProtocolDoc) {
  auto rest = mg::data_packet({0, 0, 0, 0, 0, 0});
  EXPECT_EQ(std::string(rest.begin(), rest.end()), "dH000H000H000H000H000H000\r");
  auto moved = mg::data_packet({100, -100, 0, 0, 0, 1});
  EXPECT_EQ(std::string(moved.begin(), moved.end()), "dH06DG?9<H000H000H000H00A\r");
  const auto p = mg::decode(text("dH06DG?9<H000H000H000H00A"));
  EXPECT_EQ(p.kind, mg::PacketKind::data);
  EXPECT_EQ(p.axes, (mg::Axes{100, -100, 0, 0, 0, 1}));
  const auto k = mg::decode(text("kA00"));
  EXPECT_EQ(k.kind, mg::PacketKind::keys);
  EXPECT_EQ(k.buttons, 1u);
}

TEST(MagellanPacket, ParityErrorDropsPacket) {
  // '1' (31h) is not the parity character of nibble 1 ('A').
  EXPECT_EQ(mg::decode(text("dH06DG?9<H000H000H000H001")).kind, mg::PacketKind::none);
  EXPECT_EQ(mg::decode(text("k100")).kind, mg::PacketKind::none);
  EXPECT_EQ(mg::decode(text("dH000")).kind, mg::PacketKind::none);
}

TEST(MagellanPacket, RepliesAndEchoes) {
  const auto v = mg::decode(text("v  MAGELLAN  Version 6.60  3Dconnexion GmbH 05/11/01"));
  EXPECT_EQ(v.kind, mg::PacketKind::version);
  EXPECT_TRUE(mg::is_known_version("v  MAGELLAN  Version 6.60"));
  EXPECT_TRUE(mg::is_known_version("v SPACEBALL Version 8.20"));
  EXPECT_FALSE(mg::is_known_version("v something else"));
  EXPECT_EQ(mg::decode(text("m3")).echo_type, 'm');
  EXPECT_EQ(mg::decode(text("b")).kind, mg::PacketKind::echo);
  EXPECT_EQ(mg::decode(text("e1xy")).kind, mg::PacketKind::error);
  EXPECT_EQ(mg::decode(text("X")).kind, mg::PacketKind::none);
}

TEST(MagellanPacket, VrpnInitEchoSplitsIntoFivePackets) {
  mg::Framer f;
  auto packets = frame_all(f, text("z\rm3\rc30\rnH\rb\r"));
  ASSERT_EQ(packets.size(), 5u);
  std::string letters;
  for (auto& p : packets) letters += mg::decode(p).echo_type;
  EXPECT_EQ(letters, "zmcnb");
}

TEST(MagellanPacket, OverlongGarbageDroppedThenRecovers) {
  mg::Framer f;
  Bytes wire(300, 'G');
  wire.push_back('\r');
  auto d = mg::data_packet({1, 2, 3, 4, 5, 6});
  wire.insert(wire.end(), d.begin(), d.end());
  auto packets = frame_all(f, wire);
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(mg::decode(packets[0]).axes, (mg::Axes{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(f.dropped(), 1u);
}

TEST(MagellanPacket, DataRoundTripProperty) {
  std::mt19937_64 rng(2024);
  mg::Framer f;
  for (int i = 0; i < 5000; ++i) {
    mg::Axes axes;
    for (auto& a : axes) a = static_cast<int16_t>(rng());
    const auto wire = mg::data_packet(axes);
    auto packets = frame_all(f, Bytes(wire.begin(), wire.end()));
    ASSERT_EQ(packets.size(), 1u);
    ASSERT_EQ(mg::decode(packets[0]).axes, axes);
  }
}

TEST(MagellanPacket, KeysRoundTripProperty) {
  std::mt19937_64 rng(5);
  for (int i = 0; i < 5000; ++i) {
    const auto buttons = static_cast<uint32_t>(rng()) & 0xFFFFu;  // 3 or 4 nibbles' worth
    std::array<uint8_t, 6> buf{};
    const size_t n = mg::keys_packet(buttons, buf);
    ASSERT_EQ(buf[n - 1], '\r');
    ASSERT_EQ(n, (buttons & 0xF000u) ? 6u : 5u);
    const auto p = mg::decode(std::span<const uint8_t>(buf.data(), n - 1));
    ASSERT_EQ(p.kind, mg::PacketKind::keys);
    ASSERT_EQ(p.buttons, buttons);
  }
}

TEST(MagellanPacket, FrameMappingRoundTrip) {
  mg::Scaling s;
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    mimic::devices::InputFrame in, out;
    in.translation = {u(rng), u(rng), u(rng)};
    in.rotation = {u(rng), u(rng), u(rng)};
    mg::to_frame(mg::from_frame(in, s), s, out);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(out.translation[k], in.translation[k], 1.0f / s.full_scale);
      EXPECT_NEAR(out.rotation[k], in.rotation[k], 1.0f / s.full_scale);
    }
  }
}

}  // namespace magellan_packet_test
