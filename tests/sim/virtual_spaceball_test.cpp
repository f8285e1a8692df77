// The virtual Spaceball engine byte by byte, then our driver against it over a real pty.
#include "mimic/sim/virtual_spaceball.h"

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "mimic/devices/spaceball.h"

namespace virtual_spaceball_test {

namespace sb = mimic::devices::spaceball;
using mimic::devices::DeviceState;
using mimic::devices::InputFrame;
using mimic::sim::SpaceballDevice;
using mimic::sim::VirtualSpaceballConfig;

namespace {

// Runs the engine to `until_s` in 1 ms steps and returns every decoded packet it sent.
struct Capture {
  std::vector<std::vector<uint8_t>> packets;
  std::vector<double> times;
  sb::Framer framer;
  std::vector<uint8_t> raw;
  double t = 0;
};

void run_to(SpaceballDevice& d, Capture& c, double until_s) {
  std::array<uint8_t, 256> buf{};
  for (; c.t <= until_s; c.t += 0.001) {
    d.advance(c.t);
    const size_t n = d.take_output(c.t, buf);
    for (size_t i = 0; i < n; ++i) {
      c.raw.push_back(buf[i]);
      if (c.framer.push(buf[i])) {
        c.packets.emplace_back(c.framer.packet().begin(), c.framer.packet().end());
        c.times.push_back(c.t);
      }
    }
  }
}

void host_sends(SpaceballDevice& d, const Capture& c, const std::string& s) {
  d.receive({reinterpret_cast<const uint8_t*>(s.data()), s.size()}, c.t);
}

std::vector<sb::Packet> decoded(const Capture& c, sb::PacketKind kind) {
  std::vector<sb::Packet> out;
  for (const auto& p : c.packets) {
    auto d = sb::decode(p);
    if (d.kind == kind) out.push_back(d);
  }
  return out;
}

InputFrame constant_frame() {
  InputFrame f;
  f.translation = {0.25f, -0.5f, 0.125f};
  f.rotation = {-0.25f, 0.5f, 0.75f};
  f.buttons = 0x3;  // buttons 1 and 2 exist on every model
  return f;
}

bool wait_until(const std::function<bool()>& pred, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return pred();
}

VirtualSpaceballConfig fast_config(sb::Model model) {
  VirtualSpaceballConfig c;
  c.model = model;
  c.power_up_on_open = true;  // the byte-level tests start from a cold start
  c.power_up_delay_s = 0.1;
  c.reset_delay_s = 0.05;
  c.data_period_s = 0.02;
  return c;
}

mimic::devices::SpaceballOptions fast_driver(const std::string& path) {
  mimic::devices::SpaceballOptions o;
  o.path = path;
  o.reset_timeout_s = 0.5;
  o.probe_after_s = 0.25;
  o.dead_after_s = 0.8;
  o.reconnect_interval_s = 0.1;
  return o;
}

}  // namespace

TEST(VirtualSpaceball, PowerUpBannerAfterDelay) {
  auto cfg = fast_config(sb::Model::sb3003);
  cfg.power_up_delay_s = 0.5;
  SpaceballDevice d(cfg);
  Capture c;
  d.host_opened(0.0);
  run_to(d, c, 0.49);
  EXPECT_TRUE(c.raw.empty());
  run_to(d, c, 0.7);
  ASSERT_GE(c.raw.size(), 2u);
  EXPECT_EQ(c.raw[0], 0x11);  // XON first, then CR
  EXPECT_EQ(c.raw[1], 0x0D);
  auto banners = decoded(c, sb::PacketKind::banner);
  ASSERT_EQ(banners.size(), 2u);
  EXPECT_TRUE(banners[0].banner_reset);
  EXPECT_EQ(banners[1].firmware_x100, 263);
  EXPECT_EQ(banners[1].model, sb::Model::sb3003);
  const std::string text(c.raw.begin(), c.raw.end());
  EXPECT_NE(text.find("@1 Spaceball alive and well after a poweron reset.\r\n@2 Firmware version 2.63"),
            std::string::npos);
}

// The default device was plugged in before the simulator started: a host that opens the port
// is answered at once (spacenavd gives up on a device that ignores it for 2 s), there is no
// banner, and reopening the port finds it as the last host left it.
TEST(VirtualSpaceball, PluggedInDeviceAnswersAtOnceAndKeepsItsStateAcrossOpens) {
  VirtualSpaceballConfig cfg;  // defaults: 4000 FLX, power_up_delay_s 2
  cfg.input = [](double) { return constant_frame(); };
  SpaceballDevice d(cfg);
  Capture c;
  c.t = 5.0;
  d.host_opened(c.t);
  host_sends(d, c, "\"\r");
  run_to(d, c, 5.1);
  EXPECT_TRUE(decoded(c, sb::PacketKind::banner).empty());
  const std::string text(c.raw.begin(), c.raw.end());
  EXPECT_NE(text.find("\"1 Spaceball"), std::string::npos) << text;  // the '"' reply, within 0.1 s
  host_sends(d, c, "M\r");
  run_to(d, c, 5.3);
  EXPECT_TRUE(d.data_enabled());
  EXPECT_FALSE(decoded(c, sb::PacketKind::displacement).empty());
  d.host_closed(c.t);
  d.host_opened(c.t + 1.0);
  c.t += 1.0;
  EXPECT_TRUE(d.data_enabled());  // still streaming: no power-up on open
  const size_t before = decoded(c, sb::PacketKind::displacement).size();
  run_to(d, c, c.t + 0.2);
  EXPECT_GT(decoded(c, sb::PacketKind::displacement).size(), before);
  EXPECT_TRUE(decoded(c, sb::PacketKind::banner).empty());
}

// --power-up: every open is a cold start, commands are ignored until the banner.
TEST(VirtualSpaceball, ColdStartIgnoresCommandsUntilTheBanner) {
  VirtualSpaceballConfig cfg;
  cfg.power_up_on_open = true;
  cfg.power_up_delay_s = 0.5;
  SpaceballDevice d(cfg);
  Capture c;
  d.host_opened(0.0);
  host_sends(d, c, "\"\r");
  run_to(d, c, 0.4);
  EXPECT_TRUE(c.raw.empty());
  run_to(d, c, 0.9);
  ASSERT_EQ(decoded(c, sb::PacketKind::banner).size(), 2u);
  const std::string text(c.raw.begin(), c.raw.end());
  EXPECT_EQ(text.find("\"1 Spaceball"), std::string::npos);  // the early command was ignored
}

TEST(VirtualSpaceball, NoDataUntilEnabledThenTrueIntervals) {
  auto cfg = fast_config(sb::Model::sb2003);
  cfg.input = [](double) { return constant_frame(); };
  SpaceballDevice d(cfg);
  Capture c;
  d.host_opened(0.0);
  run_to(d, c, 0.5);
  EXPECT_TRUE(decoded(c, sb::PacketKind::displacement).empty());
  host_sends(d, c, "\rCB\rMSSV\r");
  run_to(d, c, 1.5);
  auto ds = decoded(c, sb::PacketKind::displacement);
  ASSERT_GT(ds.size(), 40u);
  for (size_t i = 1; i < ds.size(); ++i) EXPECT_NEAR(ds[i].period_16th_ms, 0.02 * 16000, 16.0);
  const auto expected = sb::from_frame(constant_frame(), cfg.scaling);
  EXPECT_EQ(ds.back().axes, expected);
  auto echoes = decoded(c, sb::PacketKind::echo);
  ASSERT_GE(echoes.size(), 2u);
  // Buttons went out as a K packet once, when they changed.
  auto keys = decoded(c, sb::PacketKind::keys);
  ASSERT_EQ(keys.size(), 1u);
  EXPECT_EQ(keys[0].buttons, 0x3u);
}

TEST(VirtualSpaceball, ModelQueriesPerModel) {
  struct Case {
    sb::Model model;
    std::string firmware;
  };
  for (const auto& [model, fw] :
       {Case{sb::Model::sb2003, ""}, Case{sb::Model::sb3003, ""}, Case{sb::Model::sb4000flx, "2.42"}}) {
    auto cfg = fast_config(model);
    cfg.firmware = fw;
    cfg.right_handed = false;
    SpaceballDevice d(cfg);
    Capture c;
    d.host_opened(0.0);
    run_to(d, c, 0.2);
    host_sends(d, c, "hm\r\"\rXYZ\r");
    run_to(d, c, 0.4);
    auto models = decoded(c, sb::PacketKind::model);
    ASSERT_EQ(models.size(), 1u);
    EXPECT_EQ(models[0].model, model);
    auto bad = decoded(c, sb::PacketKind::bad_command);
    auto desc = decoded(c, sb::PacketKind::descriptor);
    if (model == sb::Model::sb4000flx) {
      EXPECT_EQ(models[0].firmware_x100, 242);
      ASSERT_EQ(desc.size(), 4u);
      EXPECT_FALSE(desc[1].right_handed);
      EXPECT_EQ(bad.size(), 1u);  // XYZ
    } else {
      EXPECT_TRUE(desc.empty());
      EXPECT_EQ(bad.size(), 2u);  // " and XYZ
    }
  }
}

TEST(VirtualSpaceball, ResetCommandResendsBannerAndStopsData) {
  auto cfg = fast_config(sb::Model::sb4000flx);
  SpaceballDevice d(cfg);
  Capture c;
  d.host_opened(0.0);
  run_to(d, c, 0.2);
  host_sends(d, c, "M\r");
  run_to(d, c, 0.5);
  EXPECT_TRUE(d.data_enabled());
  host_sends(d, c, "\r@RESET\r");
  EXPECT_FALSE(d.data_enabled());
  const size_t before = decoded(c, sb::PacketKind::banner).size();
  run_to(d, c, 0.7);
  auto banners = decoded(c, sb::PacketKind::banner);
  ASSERT_EQ(banners.size(), before + 2);
  EXPECT_EQ(d.resets(), 1u);
  const std::string text(c.raw.begin(), c.raw.end());
  EXPECT_NE(text.find("after a software reset."), std::string::npos);
}

TEST(VirtualSpaceball, OutputIsPacedAtTheBaudRate) {
  auto cfg = fast_config(sb::Model::sb4000flx);
  cfg.data_period_s = 0.001;  // asks for more than 9600 baud can carry
  SpaceballDevice d(cfg);
  Capture c;
  d.host_opened(0.0);
  run_to(d, c, 0.2);
  host_sends(d, c, "M\r");
  const size_t start = c.raw.size();
  run_to(d, c, 1.2);
  const double bytes_per_s = static_cast<double>(c.raw.size() - start) / 1.0;
  EXPECT_NEAR(bytes_per_s, 960.0, 30.0);
}

TEST(VirtualSpaceball, FaultsCorruptOnlyTheirOwnPacket) {
  auto cfg = fast_config(sb::Model::sb2003);
  cfg.input = [](double) { return constant_frame(); };
  cfg.fault_rate = 0.5;
  cfg.baud = 0;
  cfg.data_period_s = 0.005;
  SpaceballDevice d(cfg);
  Capture c;
  d.host_opened(0.0);
  run_to(d, c, 0.2);
  host_sends(d, c, "MSS\r");
  run_to(d, c, 2.2);
  const auto ds = decoded(c, sb::PacketKind::displacement);
  const auto expected = sb::from_frame(constant_frame(), cfg.scaling);
  for (const auto& p : ds) EXPECT_EQ(p.axes, expected);
  EXPECT_GT(d.faults(), 50u);
  // Each fault costs at most its own packet, and each is seen by the framer (a dropped packet)
  // or the decoder (a packet of the wrong length or with no type).
  size_t none = 0;
  for (const auto& p : c.packets) none += sb::decode(p).kind == sb::PacketKind::none;
  EXPECT_EQ(c.framer.dropped() + none, d.faults());
  EXPECT_GE(ds.size() + d.faults(), d.d_packets());
  EXPECT_LE(ds.size(), d.d_packets());
}

TEST(VirtualSpaceball, ParsesModelNames) {
  EXPECT_EQ(*mimic::sim::parse_spaceball_model("4000flx"), sb::Model::sb4000flx);
  EXPECT_EQ(*mimic::sim::parse_spaceball_model("3003"), sb::Model::sb3003);
  EXPECT_FALSE(mimic::sim::parse_spaceball_model("5000").has_value());
}

// --- Driver against the simulator over a pty ---

class SpaceballOverPty : public ::testing::TestWithParam<sb::Model> {};

TEST_P(SpaceballOverPty, DriverReceivesWhatTheDeviceSends) {
  auto cfg = fast_config(GetParam());
  cfg.input = [](double) { return constant_frame(); };
  auto server = mimic::sim::start_virtual_spaceball(cfg);
  ASSERT_TRUE(server) << server.error().what();
  auto source = mimic::devices::make_spaceball_source(fast_driver((*server)->path()));
  ASSERT_TRUE(source->start());

  InputFrame f;
  bool got = false;
  ASSERT_TRUE(wait_until(
      [&] {
        InputFrame g;
        if (source->poll(g)) {
          f = g;
          got = true;
        }
        return got && f.buttons == 0x3u && f.translation.x != 0.0f && source->status().state == DeviceState::streaming;
      },
      5.0))
      << source->status().description << " / " << source->status().last_error;
  const InputFrame want = constant_frame();
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(f.translation[k], want.translation[k], 1e-3f);
    EXPECT_NEAR(f.rotation[k], want.rotation[k], 1e-3f);
  }
  EXPECT_EQ(f.buttons, 0x3u);
  EXPECT_GT(f.host_time_s, 0.0);
  const auto st = source->status();
  EXPECT_EQ(st.state, DeviceState::streaming);
  EXPECT_NE(st.description.find(sb::model_name(GetParam())), std::string::npos) << st.description;
  EXPECT_EQ(st.resyncs, 0u);
  // The driver set the line as the Spaceball wants it.
  const auto line = (*server)->line_settings();
  EXPECT_EQ(line.baud, 9600);
  EXPECT_EQ(line.stop_bits, 1);
  EXPECT_FALSE(line.rtscts);
  EXPECT_EQ((*server)->stats().line_mismatches, 0u);
  source->stop();
}

INSTANTIATE_TEST_SUITE_P(Models, SpaceballOverPty,
                         ::testing::Values(sb::Model::sb2003, sb::Model::sb3003, sb::Model::sb4000flx),
                         [](const ::testing::TestParamInfo<sb::Model>& p) {
                           return std::string("sb") + (p.param == sb::Model::sb2003   ? "2003"
                                                       : p.param == sb::Model::sb3003 ? "3003"
                                                                                      : "4000flx");
                         });

TEST(SpaceballOverPtyRecovery, DeviceStopsAnsweringAndComesBack) {
  auto cfg = fast_config(sb::Model::sb4000flx);
  cfg.seed = 42;
  auto server = mimic::sim::start_virtual_spaceball(cfg);
  ASSERT_TRUE(server) << server.error().what();
  auto source = mimic::devices::make_spaceball_source(fast_driver((*server)->path()));
  ASSERT_TRUE(source->start());
  InputFrame f;
  ASSERT_TRUE(wait_until([&] { return source->poll(f); }, 5.0));
  EXPECT_EQ(source->status().reconnects, 0u);

  (*server)->set_muted(true);
  // Silence → probe → still silence → the port is reopened (and keeps being retried).
  ASSERT_TRUE(wait_until([&] { return source->status().reconnects >= 1; }, 5.0));
  EXPECT_NE(source->status().state, DeviceState::streaming);
  while (source->poll(f)) {}

  (*server)->set_muted(false);
  ASSERT_TRUE(wait_until([&] { return source->poll(f); }, 5.0)) << source->status().last_error;
  ASSERT_TRUE(wait_until([&] { return source->status().state == DeviceState::streaming; }, 2.0));
  source->stop();
  EXPECT_GE((*server)->stats().host_opens, 1u);
}

TEST(SpaceballOverPtyRecovery, DriverResyncsOnLineNoiseAndLostBytes) {
  auto cfg = fast_config(sb::Model::sb2003);
  cfg.input = [](double) { return constant_frame(); };
  cfg.fault_rate = 0.3;
  cfg.data_period_s = 0.01;
  cfg.seed = 11;
  auto server = mimic::sim::start_virtual_spaceball(cfg);
  ASSERT_TRUE(server) << server.error().what();
  auto source = mimic::devices::make_spaceball_source(fast_driver((*server)->path()));
  ASSERT_TRUE(source->start());
  // Every frame that gets through carries the true values: corrupt packets are dropped, never
  // half-decoded.
  const InputFrame want = constant_frame();
  int frames = 0;
  ASSERT_TRUE(wait_until(
      [&] {
        InputFrame g;
        while (source->poll(g)) {
          if (g.translation.x == 0.0f) continue;  // a K packet before the first D
          ++frames;
          for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(g.translation[k], want.translation[k], 1e-3f);
            EXPECT_NEAR(g.rotation[k], want.rotation[k], 1e-3f);
          }
        }
        return frames >= 30 && source->status().resyncs >= 5;
      },
      8.0))
      << frames << " frames, " << source->status().resyncs << " resyncs";
  EXPECT_EQ(source->status().reconnects, 0u);
  source->stop();
}

TEST(SpaceballOverPtyRecovery, PowerUpIsTheHostOpeningThePort) {
  auto cfg = fast_config(sb::Model::sb3003);
  auto server = mimic::sim::start_virtual_spaceball(cfg);
  ASSERT_TRUE(server);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ((*server)->stats().host_opens, 0u);
  EXPECT_EQ((*server)->stats().bytes_out, 0u);  // no banner into an unopened port
  auto source = mimic::devices::make_spaceball_source(fast_driver((*server)->path()));
  ASSERT_TRUE(source->start());
  ASSERT_TRUE(wait_until([&] { return source->status().state == DeviceState::streaming; }, 5.0));
  EXPECT_EQ((*server)->stats().host_opens, 1u);
  source->stop();
}

TEST(SpaceballOverPtyRecovery, MissingDeviceIsDisconnectedNotAnError) {
  auto source = mimic::devices::make_spaceball_source(fast_driver("/dev/nonexistent-spaceball"));
  ASSERT_TRUE(source->start());
  InputFrame f;
  ASSERT_TRUE(wait_until([&] { return !source->status().last_error.empty(); }, 5.0));
  EXPECT_FALSE(source->poll(f));
  const auto st = source->status();
  EXPECT_EQ(st.state, DeviceState::disconnected);
  EXPECT_NE(st.last_error.find("nonexistent-spaceball"), std::string::npos) << st.last_error;
  source->stop();
}

}  // namespace virtual_spaceball_test
