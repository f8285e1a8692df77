#include "mimic/devices/hid_packet.h"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <vector>

namespace hid_packet_test {

namespace hid = mimic::devices::hid;
using Bytes = std::vector<uint8_t>;

TEST(HidPacket, ModelTableLookups) {
  const auto* nav = hid::find_model(0x046D, 0xC626);
  ASSERT_NE(nav, nullptr);
  EXPECT_STREQ(nav->name, "SpaceNavigator");
  EXPECT_EQ(nav->buttons, 2);
  EXPECT_FALSE(nav->combined_axes);
  const auto* pro = hid::find_model(0x256F, 0xC631);
  ASSERT_NE(pro, nullptr);
  EXPECT_TRUE(pro->combined_axes);
  EXPECT_EQ(pro->buttons, 32);
  EXPECT_EQ(hid::find_model(0x256F, 0xC650), nullptr);  // CadMouse is not a 6-DOF device
  EXPECT_EQ(hid::find_model(0x046D, 0xC52B), nullptr);  // a Logitech receiver
  std::set<uint32_t> ids;
  for (const auto& m : hid::models()) ids.insert(uint32_t{m.vendor_id} << 16 | m.product_id);
  EXPECT_EQ(ids.size(), hid::models().size());
  EXPECT_EQ(ids.size(), 21u);
}

TEST(HidPacket, WorkedExamplesFromProtocolDoc) {
  // SpaceNavigator translation X = +350, Y = -350, Z = 0.
  const Bytes t = {0x01, 0x5E, 0x01, 0xA2, 0xFE, 0x00, 0x00};
  auto enc = hid::translation_report({350, -350, 0, 0, 0, 0});
  EXPECT_EQ(Bytes(enc.begin(), enc.end()), t);
  hid::Decoder d;
  EXPECT_EQ(d.feed(t), hid::kChangedTranslation);
  EXPECT_EQ(d.axes(), (hid::Axes{350, -350, 0, 0, 0, 0}));
  // 13-byte report with (10, -20, 30, -40, 50, -60).
  const Bytes c = {0x01, 0x0A, 0x00, 0xEC, 0xFF, 0x1E, 0x00, 0xD8, 0xFF, 0x32, 0x00, 0xC4, 0xFF};
  auto enc13 = hid::combined_report({10, -20, 30, -40, 50, -60});
  EXPECT_EQ(Bytes(enc13.begin(), enc13.end()), c);
  EXPECT_EQ(d.feed(c), hid::kChangedTranslation | hid::kChangedRotation);
  EXPECT_EQ(d.axes(), (hid::Axes{10, -20, 30, -40, 50, -60}));
}

TEST(HidPacket, ParsesByIdNotLength) {
  hid::Decoder d;
  // Trailing bytes after a rotation report's six are ignored.
  Bytes rot = {0x02, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0xAA, 0xBB};
  EXPECT_EQ(d.feed(rot), hid::kChangedRotation);
  EXPECT_EQ(d.axes(), (hid::Axes{0, 0, 0, 1, 2, 3}));
  // Buttons: Linux gives 3 bytes, macOS 2.
  EXPECT_EQ(d.feed(Bytes{0x03, 0x02, 0x00}), hid::kChangedButtons);
  EXPECT_EQ(d.buttons(), 2u);
  EXPECT_EQ(d.feed(Bytes{0x03, 0x02}), hid::kChangedNone);
  // Battery and unknown reports.
  EXPECT_EQ(d.feed(Bytes{0x17, 0x55}), hid::kChangedBattery);
  EXPECT_EQ(d.battery_percent(), 0x55);
  EXPECT_EQ(d.feed(Bytes{0x09, 1, 2}), hid::kUnknownReport);
  EXPECT_EQ(d.feed(Bytes{0x01, 1, 2}), hid::kUnknownReport);  // truncated
  EXPECT_EQ(d.feed(Bytes{}), hid::kUnknownReport);
  EXPECT_EQ(d.unknown_reports(), 3u);
  EXPECT_EQ(d.axes(), (hid::Axes{0, 0, 0, 1, 2, 3}));  // untouched by the bad ones
}

TEST(HidPacket, ReportRoundTripProperty) {
  std::mt19937_64 rng(77);
  hid::Decoder split, combined;
  for (int i = 0; i < 5000; ++i) {
    hid::Axes a;
    for (auto& v : a) v = static_cast<int16_t>(rng());
    split.feed(hid::translation_report(a));
    split.feed(hid::rotation_report(a));
    combined.feed(hid::combined_report(a));
    ASSERT_EQ(split.axes(), a);
    ASSERT_EQ(combined.axes(), a);
    const auto buttons = static_cast<uint32_t>(rng());
    const unsigned count = 1 + static_cast<unsigned>(rng() % 32);
    std::array<uint8_t, 5> buf{};
    const size_t n = hid::button_report(buttons, count, buf);
    split.feed(std::span<const uint8_t>(buf.data(), n));
    const uint32_t mask = (n - 1) >= 4 ? 0xFFFFFFFFu : ((1u << (8 * (n - 1))) - 1);
    ASSERT_EQ(split.buttons(), buttons & mask);
  }
}

TEST(HidPacket, FrameMappingFollowsSpacenavdConvention) {
  hid::Scaling s;
  mimic::devices::InputFrame f;
  // Raw +Z presses down → frame −Y; raw +Y toward the user → frame +Z.
  hid::to_frame({175, 350, 350, 0, 175, -350}, s, f);
  EXPECT_FLOAT_EQ(f.translation.x, 0.5f);
  EXPECT_FLOAT_EQ(f.translation.y, -1.0f);
  EXPECT_FLOAT_EQ(f.translation.z, 1.0f);
  EXPECT_FLOAT_EQ(f.rotation.y, 1.0f);
  EXPECT_FLOAT_EQ(f.rotation.z, 0.5f);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    mimic::devices::InputFrame in, out;
    in.translation = {u(rng), u(rng), u(rng)};
    in.rotation = {u(rng), u(rng), u(rng)};
    hid::to_frame(hid::from_frame(in, s), s, out);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(out.translation[k], in.translation[k], 0.5f / s.full_scale + 1e-6f);
      EXPECT_NEAR(out.rotation[k], in.rotation[k], 0.5f / s.full_scale + 1e-6f);
    }
  }
}

}  // namespace hid_packet_test
