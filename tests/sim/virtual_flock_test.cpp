// The virtual Flock of Birds, driven byte by byte from a plain POSIX host end: what a real unit
// answers, in the sizes and encodings of the manual.
#include <cstring>

#include <gtest/gtest.h>

#include "flock_test_support.h"
#include "mimic/devices/flock_packet.h"

namespace mimic::sim::virtual_flock_test {
namespace {

namespace fl = devices::flock;
using namespace std::chrono_literals;
using Bytes = std::vector<uint8_t>;

struct Served {
  std::unique_ptr<VirtualFlock> flock;
  std::unique_ptr<test::RawHost> host;
};

Served serve(VirtualFlockConfig cfg) {
  cfg.boot_garbage = false;
  Served s;
  auto f = VirtualFlock::create(std::move(cfg));
  EXPECT_TRUE(f) << f.error().what();
  s.flock = std::move(*f);
  EXPECT_TRUE(s.flock->start());
  s.host = std::make_unique<test::RawHost>(s.flock->slave_path());
  EXPECT_TRUE(s.host->ok());
  return s;
}

Bytes examine(test::RawHost& h, uint8_t p, int address = -1) {
  Bytes c;
  fl::append_examine(c, p, address);
  h.send(c);
  // The reply always comes; a loaded machine may take seconds to run the simulator's thread.
  return h.read(static_cast<size_t>(fl::examine_size(p)), std::chrono::seconds(10));
}

TEST(VirtualFlock, StandaloneIdentifiesItself) {
  auto s = serve(test::fast_sim(1));
  auto& h = *s.host;
  EXPECT_EQ(examine(h, fl::param::kSoftwareRevision), (Bytes{0x03, 0x43}));
  EXPECT_EQ(examine(h, fl::param::kCrystalSpeed), (Bytes{0x19, 0x00}));
  const Bytes model = examine(h, fl::param::kSystemModel);
  EXPECT_EQ(std::string(model.begin(), model.end()), "6DFOB     ");
  EXPECT_EQ(examine(h, fl::param::kFbbAddress), (Bytes{0}));
  const Bytes status = examine(h, fl::param::kStatus);
  ASSERT_EQ(status.size(), 2u);
  const fl::BirdStatus st = fl::decode_status(static_cast<uint16_t>(fl::get_le16(status.data())));
  EXPECT_TRUE(st.master);
  EXPECT_TRUE(st.running);
  EXPECT_FALSE(st.sleeping);
  EXPECT_FALSE(st.streaming);
  EXPECT_EQ(st.format, fl::Format::position_angles);  // the power-up format
  EXPECT_EQ(examine(h, fl::param::kAutoConfig), (Bytes{0, 1, 0, 0, 0}));
  // Measurement rate: the count for 103.3 Hz at 25 MHz.
  const Bytes count = examine(h, fl::param::kMeasurementRateCount);
  EXPECT_NEAR(fl::measurement_rate_hz(fl::get_le16(count.data()), 25.0), 103.3, 0.05);
}

TEST(VirtualFlock, ChangeIsNeverAcknowledgedAndExamineReadsItBack) {
  auto s = serve(test::fast_sim(1));
  auto& h = *s.host;
  Bytes c;
  fl::append_change_word(c, fl::param::kPositionScaling, 1);
  fl::append_hemisphere(c, fl::Hemisphere::lower);
  fl::append_format(c, fl::Format::quaternion);
  h.send(c);
  EXPECT_TRUE(h.drain(100ms).empty());
  EXPECT_EQ(examine(h, fl::param::kPositionScaling), (Bytes{1, 0}));
  EXPECT_EQ(examine(h, fl::param::kHemisphere), (Bytes{0x0C, 0x00}));
  const Bytes status = examine(h, fl::param::kStatus);
  EXPECT_EQ(fl::decode_status(static_cast<uint16_t>(fl::get_le16(status.data()))).format, fl::Format::quaternion);
}

TEST(VirtualFlock, InvalidCommandSetsErrorSixAndReadingClearsIt) {
  auto s = serve(test::fast_sim(1));
  auto& h = *s.host;
  h.send({'x'});
  EXPECT_EQ(examine(h, fl::param::kErrorCode), (Bytes{6}));
  EXPECT_EQ(examine(h, fl::param::kErrorCode), (Bytes{0}));
  // A read-only parameter cannot be changed.
  h.send({'P', fl::param::kSystemModel});
  EXPECT_EQ(examine(h, fl::param::kExpandedErrorCode), (Bytes{6, 0}));
  EXPECT_GE(s.flock->stats().invalid_commands, 2u);
}

TEST(VirtualFlock, PointRecordIsTheWorkedExampleOfTheManual) {
  // Bird 2 of a 2-bird flock in group mode, POS/ANGLES: X=+18 in, Y=-9, Z=+4.5; az 90, el 0,
  // roll -45 -> 80 20 00 70 00 08 00 20 00 00 00 70 02.
  VirtualFlockConfig cfg = test::fast_sim(2);
  cfg.provider = [](double, int, devices::SensorSample& out) {
    const fl::Measurement m =
        fl::measurement_from_pose(glm::dvec3(18, -9, 4.5), fl::transmitter_from_sensor_from_angles({90, 0, -45}));
    const glm::dmat3 c = fl::mimic_from_flock();
    out.position_m = glm::vec3(c * m.position_in * 0.0254);
    out.orientation = glm::quat(glm::quat_cast(c * glm::transpose(m.matrix) * glm::transpose(c)));
  };
  auto s = serve(cfg);
  auto& h = *s.host;
  h.send({'P', fl::param::kAutoConfig, 2});
  std::this_thread::sleep_for(100ms);
  h.send({0xF2, 'Y', 'P', fl::param::kGroupMode, 1});
  h.send({0xF1, 'Y'});
  h.send({'B'});
  const Bytes r = h.read(26);
  ASSERT_EQ(r.size(), 26u);
  const Bytes bird2(r.begin() + 13, r.end());
  EXPECT_EQ(bird2, (Bytes{0x80, 0x20, 0x00, 0x70, 0x00, 0x08, 0x00, 0x20, 0x00, 0x00, 0x00, 0x70, 0x02}));
  EXPECT_EQ(r[12], 0x01);  // bird 1's group byte
}

TEST(VirtualFlock, FlockNeedsAutoConfigurationAndReportsItsUnits) {
  VirtualFlockConfig cfg = test::fast_sim(3);
  cfg.erc = true;  // ERC at 1, birds at 2, 3, 4
  auto s = serve(cfg);
  auto& h = *s.host;
  Bytes fs = examine(h, fl::param::kFlockStatus);
  ASSERT_EQ(fs.size(), 14u);
  EXPECT_EQ(fs[0], fl::kUnitAccessible | fl::kUnitErc | fl::kUnitTransmitter);  // not running yet
  EXPECT_EQ(fs[1], fl::kUnitAccessible | fl::kUnitSensor);
  EXPECT_EQ(fs[4], 0);  // nobody at address 5
  h.send({'B'});        // not configured: no record (drivers send B first just to stop a stream)
  EXPECT_TRUE(h.drain(80ms).empty());
  EXPECT_EQ(examine(h, fl::param::kErrorCode), (Bytes{0}));
  h.send({'@'});  // streaming needs a configured flock: error 8 (no birds active)
  EXPECT_TRUE(h.drain(80ms).empty());
  EXPECT_EQ(examine(h, fl::param::kErrorCode), (Bytes{8}));

  h.send({'P', fl::param::kAutoConfig, 4});
  h.send({'O', fl::param::kStatus});  // arrives inside the busy window: dropped
  EXPECT_TRUE(h.drain(120ms).empty());
  EXPECT_GT(s.flock->stats().dropped_while_busy, 0u);
  fs = examine(h, fl::param::kFlockStatus);
  EXPECT_EQ(fs[0], 0xD1);  // ERC: accessible, running, ERC, transmitter
  EXPECT_EQ(fs[1], 0xE0);  // sensor-only birds, running
  EXPECT_EQ(fs[3], 0xE0);
  EXPECT_EQ(examine(h, fl::param::kAutoConfig), (Bytes{1, 0x1E, 0, 0, 0}));
  const Bytes model = examine(h, fl::param::kSystemModel);
  EXPECT_EQ(std::string(model.begin(), model.end()), "6DERC     ");
  const Bytes bird_model = examine(h, fl::param::kSystemModel, 3);
  EXPECT_EQ(std::string(bird_model.begin(), bird_model.end()), "6DFOB     ");
  EXPECT_EQ(examine(h, fl::param::kFbbAddress, 4), (Bytes{4}));
  // Asking for more units than are on the bus fails with error 13 and the missing address.
  h.send({'P', fl::param::kAutoConfig, 6});
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(examine(h, fl::param::kExpandedErrorCode), (Bytes{13, 5}));
}

// VRPN's vrpn_Tracker_Flock::reset byte sequence (device-protocols.md §1.9), timings shortened:
// what another project's driver sends must get what it expects.
TEST(VirtualFlock, AnswersVrpnResetSequence) {
  auto s = serve(test::fast_sim(4));
  auto& h = *s.host;
  h.send({'B'});
  std::this_thread::sleep_for(20ms);
  h.drain(20ms);
  h.send({'P', 0x32, 4});  // auto-configuration, 4 units
  std::this_thread::sleep_for(100ms);
  Bytes burst = {'P', 0x23, 0x01};  // group mode
  for (int i = 1; i <= 4; ++i) {
    burst.push_back(fl::fbb_prefix(i));
    burst.push_back(']');
  }
  for (int i = 1; i <= 4; ++i) {
    burst.push_back(fl::fbb_prefix(i));
    burst.push_back('L');
    burst.push_back(0x0C);
    burst.push_back(0x00);
  }
  h.send(burst);
  EXPECT_TRUE(h.drain(50ms).empty());  // no acknowledgements
  h.send({'O', 0x24});
  const Bytes fs = h.read(14);
  ASSERT_EQ(fs.size(), 14u);
  for (int a = 0; a < 4; ++a) EXPECT_EQ(fs[static_cast<size_t>(a)] & 0xC0, 0xC0) << a;  // VRPN checks 80h and 40h
  h.send({'O', 0x02, 'O', 0x06});
  const Bytes cc = h.read(4);
  ASSERT_EQ(cc.size(), 4u);
  EXPECT_EQ(cc[0], 25);
  EXPECT_NEAR(fl::measurement_rate_hz(fl::get_le16(&cc[2]), cc[0]), 103.3, 0.05);
  h.send({'@'});
  // 15-byte POS/QUAT group records, addresses 1..4 in order.
  fl::StreamDecoder d({fl::Format::position_quaternion, false, true});
  std::vector<int> addresses;
  d.feed(h.read(15 * 8), [&](const fl::RawRecord& r, size_t) { addresses.push_back(r.address); });
  EXPECT_EQ(addresses, (std::vector<int>{1, 2, 3, 4, 1, 2, 3, 4}));
  // Error check and shutdown: B G, flush, O 10h -> 2 bytes.
  h.send({'B', 'G'});
  std::this_thread::sleep_for(30ms);
  h.drain(20ms);
  h.send({'O', 0x10});
  EXPECT_EQ(h.read(2), (Bytes{0, 0}));
  EXPECT_TRUE(s.flock->stats().sleeping);
}

TEST(VirtualFlock, PrefixCoversOnlyTheNextCommand) {
  auto s = serve(test::fast_sim(2));
  auto& h = *s.host;
  h.send({'P', fl::param::kAutoConfig, 2});
  std::this_thread::sleep_for(100ms);
  h.send({0xF2, 'V', 'X'});  // bird 2 -> POSITION, then the master -> MATRIX
  auto st = [&](int a) {
    const Bytes b = examine(h, fl::param::kStatus, a);
    EXPECT_EQ(b.size(), 2u) << "bird " << a << "'s status word";
    if (b.size() != 2) return std::optional<fl::Format>();  // no word to decode
    return fl::decode_status(static_cast<uint16_t>(fl::get_le16(b.data()))).format;
  };
  EXPECT_EQ(st(2), fl::Format::position);
  EXPECT_EQ(st(1), fl::Format::matrix);
  // A prefix to an address nobody has: error 13 with that address.
  h.send({0xF9, 'B'});
  EXPECT_EQ(examine(h, fl::param::kExpandedErrorCode), (Bytes{13, 9}));
}

TEST(VirtualFlock, StreamIsPacedAndPointStopsIt) {
  auto s = serve(test::fast_sim(1));
  auto& h = *s.host;
  h.send({'V', '@'});
  // Records come until 16 have (however late a loaded machine runs the simulator), never faster
  // than ~103 Hz allows for the time they took (an unpaced stream would send thousands).
  const auto t0 = std::chrono::steady_clock::now();
  Bytes burst;
  while (burst.size() < 6u * 16 && std::chrono::steady_clock::now() - t0 < 10s) {
    const Bytes b = h.drain(50ms);
    burst.insert(burst.end(), b.begin(), b.end());
  }
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(burst.size(), 6u * 16);
  EXPECT_LE(burst.size(), 6u * size_t(elapsed_s * 103.3 * 1.5 + 8)) << elapsed_s << " s";
  h.send({'B'});
  std::this_thread::sleep_for(50ms);
  h.drain(30ms);
  EXPECT_TRUE(h.drain(100ms).empty());  // stopped
  EXPECT_FALSE(s.flock->stats().streaming);
  // Sleep stops output; run resumes it.
  h.send({'G', 'B'});
  EXPECT_TRUE(h.drain(80ms).empty());
  h.send({'F', 'B'});
  EXPECT_EQ(h.read(6).size(), 6u);
}

TEST(VirtualFlock, ReportRateDividesTheStream) {
  auto s = serve(test::fast_sim(1));
  auto& h = *s.host;
  h.send({'V', 'S', '@'});  // every 8th measurement: ~13 Hz
  const Bytes burst = h.drain(400ms);
  EXPECT_LE(burst.size(), 6u * 8);
  EXPECT_GE(burst.size(), 6u * 2);
}

TEST(VirtualFlock, HemisphereMirrorsPositionsIntoIt) {
  VirtualFlockConfig cfg = test::fast_sim(1);
  // A sensor behind the transmitter (Mimic -Z = Flock -X).
  cfg.provider = [](double, int, devices::SensorSample& out) { out.position_m = {0.1f, 0.0f, -0.3f}; };
  auto s = serve(cfg);
  auto& h = *s.host;
  auto x_in = [&] {
    h.send({'V', 'B'});
    const Bytes r = h.read(6);
    fl::RawRecord raw = *fl::decode_record(r, {fl::Format::position, false, false});
    return fl::from_raw(raw, fl::PositionRange::in36).position_in;
  };
  EXPECT_GT(x_in().x, 0);  // forward hemisphere: reported mirrored in front
  h.send({'L', 0x00, 0x01});
  const glm::dvec3 aft = x_in();
  EXPECT_NEAR(aft.x, -0.3 / 0.0254, 0.01);
  EXPECT_NEAR(aft.y, -0.1 / 0.0254, 0.01);
}

TEST(VirtualFlock, HostLineSettingsAreChecked) {
  VirtualFlockConfig cfg = test::fast_sim(1);
  cfg.boot_garbage = false;
  auto f = VirtualFlock::create(cfg);
  ASSERT_TRUE(f);
  ASSERT_TRUE((*f)->start());
  test::RawHost wrong((*f)->slave_path(), B9600);
  wrong.send({'O', 0});
  wrong.read(2);
  EXPECT_EQ((*f)->stats().line_mismatches, 1u);
}

TEST(VirtualFlock, ResetSendsBootNoiseAndForgetsConfiguration) {
  VirtualFlockConfig cfg = test::fast_sim(2);
  auto s = serve(cfg);
  auto& h = *s.host;
  h.send({'P', fl::param::kAutoConfig, 2});
  std::this_thread::sleep_for(100ms);
  EXPECT_TRUE(s.flock->stats().configured);
  s.flock.reset();  // (stop the fixture's clean flock; use a noisy one)
  cfg.boot_garbage = true;
  auto f = VirtualFlock::create(cfg);
  ASSERT_TRUE(f);
  ASSERT_TRUE((*f)->start());
  test::RawHost host((*f)->slave_path());
  host.send({'P', fl::param::kAutoConfig, 2});
  std::this_thread::sleep_for(100ms);
  (*f)->reset();
  const Bytes noise = host.drain(100ms);
  EXPECT_GE(noise.size(), 3u);
  EXPECT_FALSE((*f)->stats().configured);
}

TEST(VirtualFlock, SameSeedSameBytes) {
  auto capture = [] {
    VirtualFlockConfig cfg;
    cfg.birds = 1;
    cfg.seed = 99;
    cfg.boot_garbage = false;
    auto f = VirtualFlock::create(cfg);
    EXPECT_TRUE(f);
    EXPECT_TRUE((*f)->start());
    test::RawHost h((*f)->slave_path());
    Bytes all;
    // Point records sample the motion at the command's time, which differs run to run; the
    // identification replies and injected garbage are what the seed fixes.
    for (int pi : {0, 1, 2, 15, 36, 50}) {
      const auto p = static_cast<uint8_t>(pi);
      h.send({'O', p});
      const Bytes r = h.read(static_cast<size_t>(fl::examine_size(p)));
      all.insert(all.end(), r.begin(), r.end());
    }
    (*f)->inject_garbage(40);
    const Bytes g = h.read(40);
    all.insert(all.end(), g.begin(), g.end());
    return all;
  };
  const Bytes a = capture(), b = capture();
  EXPECT_EQ(a.size(), 2u + 2 + 2 + 10 + 14 + 5 + 40);
  EXPECT_EQ(a, b);
}

TEST(VirtualFlock, BuiltinMotionMovesAndStaysInRange) {
  auto provider = make_builtin_flock_motion(5);
  for (int bird = 0; bird < 14; ++bird) {
    devices::SensorSample a, b;
    provider(0.0, bird, a);
    provider(0.7, bird, b);
    EXPECT_NEAR(glm::length(a.orientation), 1.0f, 1e-4f);
    const fl::Measurement m = fl::measurement_from_sample(b);
    EXPECT_TRUE(fl::in_hemisphere(fl::Hemisphere::forward, m.position_in)) << bird;
    EXPECT_LT(glm::length(m.position_in), 72.0) << bird;
    if (bird != 0) {
      EXPECT_GT(glm::length(a.position_m - b.position_m) + (1.0f - std::abs(glm::dot(a.orientation, b.orientation))),
                1e-4f)
          << bird;
    }
  }
}

}  // namespace
}  // namespace mimic::sim::virtual_flock_test
