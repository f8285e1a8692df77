// The virtual Magellan engine byte by byte, then our driver against it over a real pty.
#include "mimic/sim/virtual_magellan.h"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <string>
#include <thread>

#include "mimic/devices/magellan.h"

namespace virtual_magellan_test {

namespace mg = mimic::devices::magellan;
using mimic::devices::DeviceState;
using mimic::devices::InputFrame;
using mimic::sim::MagellanDevice;
using mimic::sim::VirtualMagellanConfig;

namespace {

std::string run(MagellanDevice& d, double& t, double until_s) {
  std::string out;
  std::array<uint8_t, 256> buf{};
  for (; t <= until_s; t += 0.001) {
    d.advance(t);
    const size_t n = d.take_output(t, buf);
    out.append(reinterpret_cast<const char*>(buf.data()), n);
  }
  return out;
}

void host_sends(MagellanDevice& d, double t, const std::string& s) {
  d.receive({reinterpret_cast<const uint8_t*>(s.data()), s.size()}, t);
}

InputFrame constant_frame() {
  InputFrame f;
  f.translation = {0.5f, -0.25f, 0.125f};
  f.rotation = {0.25f, -0.75f, 0.5f};
  f.buttons = 1u | 1u << 8;  // key 1 and '*'
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

mimic::devices::MagellanOptions fast_driver(const std::string& path) {
  mimic::devices::MagellanOptions o;
  o.path = path;
  o.settle_s = 0.05;
  o.query_retry_s = 0.3;
  o.probe_after_s = 0.25;
  o.dead_after_s = 0.8;
  o.reconnect_interval_s = 0.1;
  return o;
}

}  // namespace

TEST(VirtualMagellan, EchoesExactlyWhatVrpnExpects) {
  VirtualMagellanConfig cfg;
  cfg.input = mimic::sim::rest_pattern();
  MagellanDevice d(cfg);
  double t = 0;
  d.host_opened(t);
  host_sends(d, t, "z\rm3\rc30\rnH\rbH\r");
  const std::string out = run(d, t, 0.2);
  // After the echoes the device reports its (resting) values once, because m3 enabled data.
  ASSERT_GE(out.size(), 14u);
  EXPECT_EQ(out.substr(0, 14), "z\rm3\rc30\rnH\rb\r");
  EXPECT_EQ(out.substr(14), "dH000H000H000H000H000H000\r");
  EXPECT_EQ(d.mode(), 3u);
}

TEST(VirtualMagellan, VersionQueryAndSilenceTowardsSpaceballProbe) {
  VirtualMagellanConfig cfg;
  MagellanDevice d(cfg);
  double t = 0;
  d.host_opened(t);
  host_sends(d, t, "\r@RESET\r");
  EXPECT_EQ(run(d, t, 0.3), "");
  host_sends(d, t, "vQ\r");
  const std::string v = run(d, t, 0.5);
  EXPECT_EQ(v, "v" + cfg.version + "\r");
  EXPECT_TRUE(mg::is_known_version(v));
  host_sends(d, t, "xy\r");
  EXPECT_EQ(run(d, t, 0.6), "e1xy\r");
}

TEST(VirtualMagellan, DataPacketsAreValidParityAndOnlyOnChange) {
  VirtualMagellanConfig cfg;
  cfg.seed = 9;
  MagellanDevice d(cfg);
  double t = 0;
  d.host_opened(t);
  host_sends(d, t, "m3\r");
  const std::string out = run(d, t, 2.0);
  mg::Framer f;
  size_t data = 0, keys = 0, echoes = 0;
  for (char c : out) {
    if (!f.push(static_cast<uint8_t>(c))) continue;
    const auto p = mg::decode(f.packet());
    ASSERT_NE(p.kind, mg::PacketKind::none);
    data += p.kind == mg::PacketKind::data;
    keys += p.kind == mg::PacketKind::keys;
    echoes += p.kind == mg::PacketKind::echo;
  }
  EXPECT_EQ(echoes, 1u);
  // 2 s at one packet per 20 ms while moving; 9600 baud 8N2 carries ~872 B/s = 33 packets/s.
  EXPECT_GT(data, 50u);
  EXPECT_LT(data, 101u);
  EXPECT_GE(keys, 1u);  // the default pattern presses a button between 1.0 and 1.3 s
}

TEST(VirtualMagellan, DriverOverPty) {
  VirtualMagellanConfig cfg;
  cfg.input = [](double) { return constant_frame(); };
  auto server = mimic::sim::start_virtual_magellan(cfg);
  ASSERT_TRUE(server) << server.error().what();
  auto source = mimic::devices::make_magellan_source(fast_driver((*server)->path()));
  ASSERT_TRUE(source->start());
  InputFrame f;
  ASSERT_TRUE(wait_until(
      [&] {
        InputFrame g;
        if (source->poll(g)) f = g;
        return f.translation.x != 0.0f && f.buttons != 0 && source->status().state == DeviceState::streaming;
      },
      5.0))
      << source->status().last_error;
  const InputFrame want = constant_frame();
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(f.translation[k], want.translation[k], 1e-3f);
    EXPECT_NEAR(f.rotation[k], want.rotation[k], 1e-3f);
  }
  EXPECT_EQ(f.buttons, want.buttons);
  const auto st = source->status();
  EXPECT_NE(st.description.find("MAGELLAN"), std::string::npos) << st.description;
  const auto line = (*server)->line_settings();
  EXPECT_EQ(line.baud, 9600);
  EXPECT_EQ(line.stop_bits, 2);
  EXPECT_TRUE(line.rtscts);
  EXPECT_EQ((*server)->stats().line_mismatches, 0u);
  source->stop();
}

TEST(VirtualMagellan, HostWithTheWrongLineIsNoticed) {
  // VRPN opens a Magellan 8N1 without handshake; the simulator notes it (and still answers).
  auto server = mimic::sim::start_virtual_magellan({});
  ASSERT_TRUE(server);
  const int fd = ::open((*server)->path().c_str(), O_RDWR | O_NOCTTY);
  ASSERT_GE(fd, 0);
  termios t{};
  ASSERT_EQ(::tcgetattr(fd, &t), 0);
  ::cfmakeraw(&t);
  ::cfsetspeed(&t, B19200);
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS);
  ASSERT_EQ(::tcsetattr(fd, TCSANOW, &t), 0);
  ASSERT_EQ(::write(fd, "vQ\r", 3), 3);
  ASSERT_TRUE(wait_until([&] { return (*server)->stats().bytes_out > 0; }, 3.0));
  EXPECT_EQ((*server)->stats().line_mismatches, 1u);
  ::close(fd);
}

TEST(VirtualMagellan, DriverReconnectsWhenDeviceComesBack) {
  VirtualMagellanConfig cfg;
  auto server = mimic::sim::start_virtual_magellan(cfg);
  ASSERT_TRUE(server);
  auto source = mimic::devices::make_magellan_source(fast_driver((*server)->path()));
  ASSERT_TRUE(source->start());
  InputFrame f;
  ASSERT_TRUE(wait_until([&] { return source->poll(f); }, 5.0));
  (*server)->set_muted(true);
  ASSERT_TRUE(wait_until([&] { return source->status().reconnects >= 1; }, 5.0));
  while (source->poll(f)) {}
  (*server)->set_muted(false);
  ASSERT_TRUE(wait_until([&] { return source->poll(f); }, 5.0));
  ASSERT_TRUE(wait_until([&] { return source->status().state == DeviceState::streaming; }, 2.0));
  source->stop();
}

}  // namespace virtual_magellan_test
