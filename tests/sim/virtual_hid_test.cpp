// Simulated 3Dconnexion HID reports through the decoder the hidapi driver uses.
#include "mimic/sim/virtual_hid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "mimic/devices/hid_spacemouse.h"

namespace virtual_hid_test {

namespace hid = mimic::devices::hid;
using mimic::devices::InputFrame;
using mimic::sim::VirtualHid;
using mimic::sim::VirtualHidConfig;

namespace {

struct Report {
  double t;
  std::vector<uint8_t> bytes;
};

std::vector<Report> collect(VirtualHid& v, double until_s) {
  std::vector<Report> out;
  for (double t = 0; t <= until_s; t += 0.001) {
    v.advance(t, [&](std::span<const uint8_t> r) { out.push_back({t, {r.begin(), r.end()}}); });
  }
  return out;
}

}  // namespace

TEST(VirtualHid, SpaceNavigatorAlternatesReportsEvery8msThenGoesQuietAtRest) {
  VirtualHidConfig cfg;
  cfg.input = [](double t) {
    InputFrame f;
    if (t < 0.1) f.translation = {0.5f, 0.0f, 0.0f};
    if (t >= 0.05 && t < 0.08) f.buttons = 1;
    return f;
  };
  VirtualHid v(cfg);
  const auto reports = collect(v, 0.5);
  std::vector<Report> axes;
  for (const auto& r : reports) {
    if (r.bytes[0] == 1 || r.bytes[0] == 2) axes.push_back(r);
    EXPECT_NE(r.bytes[0], 0x17);  // wired device: no battery
  }
  ASSERT_GT(axes.size(), 10u);
  for (size_t i = 1; i < axes.size(); ++i) {
    EXPECT_NE(axes[i].bytes[0], axes[i - 1].bytes[0]);  // 1, 2, 1, 2 …
    EXPECT_EQ(axes[i].bytes.size(), 7u);
  }
  for (size_t i = 1; i < 12; ++i) EXPECT_NEAR(axes[i].t - axes[i - 1].t, 0.008, 0.0011);
  // Movement lasts 0.1 s (13 reports), then exactly six zero reports (three of each), then
  // silence.
  size_t zeros = 0;
  for (const auto& r : axes) {
    if (r.t >= 0.1) {
      ++zeros;
      EXPECT_TRUE(std::all_of(r.bytes.begin() + 1, r.bytes.end(), [](uint8_t b) { return b == 0; }));
    }
  }
  EXPECT_EQ(zeros, 6u);
  EXPECT_LT(axes.back().t, 0.16);
  // Report 3 exactly on the two button changes.
  size_t button_reports = 0;
  for (const auto& r : reports) button_reports += r.bytes[0] == 3;
  EXPECT_EQ(button_reports, 2u);
}

TEST(VirtualHid, WirelessModelSendsCombinedReportsAndBattery) {
  VirtualHidConfig cfg;
  cfg.vendor_id = hid::kVendor3Dconnexion;
  cfg.product_id = 0xC62E;
  cfg.battery_period_s = 0.2;
  cfg.seed = 4;
  VirtualHid v(cfg);
  const auto reports = collect(v, 1.0);
  size_t combined = 0, battery = 0;
  hid::Decoder d;
  for (const auto& r : reports) {
    d.feed(r.bytes);
    if (r.bytes[0] == 1) {
      EXPECT_EQ(r.bytes.size(), 13u);
      ++combined;
    }
    EXPECT_NE(r.bytes[0], 2);
    battery += r.bytes[0] == 0x17;
  }
  EXPECT_NEAR(static_cast<double>(combined), 1.0 / 0.016, 2.0);
  EXPECT_EQ(battery, 5u);
  EXPECT_GE(d.battery_percent(), 90);
  EXPECT_EQ(d.unknown_reports(), 0u);
}

TEST(VirtualHid, DecodedFramesMatchThePattern) {
  // Property: what the decoder reports equals the pattern at the report's time, to one count.
  VirtualHidConfig cfg;
  cfg.seed = 77;
  const auto pattern = mimic::sim::default_input_pattern(cfg.seed);
  VirtualHid v(cfg);
  hid::Decoder d;
  int checked = 0;
  for (double t = 0; t <= 3.0; t += 0.001) {
    v.advance(t, [&](std::span<const uint8_t> r) {
      d.feed(r);
      if (r[0] != 2) return;
      // A rotation report carries the pattern at its 8 ms slot, which began at most 1 ms ago.
      const double slot_s = std::floor((t + 1e-9) / 0.008) * 0.008;
      InputFrame got;
      hid::to_frame(d.axes(), cfg.scaling, got);
      const InputFrame want = pattern(slot_s);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(got.rotation[k], want.rotation[k], 0.01f) << t;
      ++checked;
    });
  }
  EXPECT_GT(checked, 100);
}

TEST(VirtualHid, SimulatedSpaceMouseIsAnInputSource) {
  VirtualHidConfig cfg;
  cfg.input = [](double) {
    InputFrame f;
    f.translation = {0.2f, -0.4f, 0.6f};
    f.rotation = {-0.2f, 0.4f, -0.6f};
    f.buttons = 2;
    return f;
  };
  auto src = mimic::sim::make_simulated_spacemouse(cfg);
  ASSERT_TRUE(src);
  ASSERT_TRUE((*src)->start());
  InputFrame f;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  bool got = false;
  while (std::chrono::steady_clock::now() < end) {
    InputFrame g;
    if ((*src)->poll(g)) {
      f = g;
      if (f.rotation.z != 0.0f && f.buttons == 2) {
        got = true;
        break;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_TRUE(got);
  EXPECT_NEAR(f.translation.x, 0.2f, 0.003f);
  EXPECT_NEAR(f.translation.y, -0.4f, 0.003f);
  EXPECT_NEAR(f.translation.z, 0.6f, 0.003f);
  EXPECT_NEAR(f.rotation.x, -0.2f, 0.003f);
  EXPECT_NEAR(f.rotation.y, 0.4f, 0.003f);
  EXPECT_NEAR(f.rotation.z, -0.6f, 0.003f);
  EXPECT_NE((*src)->status().description.find("SpaceNavigator"), std::string::npos);
  (*src)->stop();
  VirtualHidConfig unknown;
  unknown.vendor_id = 0x1234;
  EXPECT_FALSE(mimic::sim::make_simulated_spacemouse(unknown).has_value());
}

}  // namespace virtual_hid_test
