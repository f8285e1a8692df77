// Flock of Birds codec: word encoding, record layouts, scaling, frames, command bytes.
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "mimic/devices/flock_packet.h"

namespace mimic::devices::flock::flock_packet_test {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(FlockWord, AscensionGuideExample) {
  // Bytes C8 08 decode to 1120h (Ascension's worked example).
  EXPECT_EQ(decode_word(0xC8, 0x08), 0x1120);
  uint8_t b[2];
  encode_word(0x1120, b, true);
  EXPECT_EQ(b[0], 0xC8);
  EXPECT_EQ(b[1], 0x08);
}

TEST(FlockWord, RoundTripAllValuesDropsLowTwoBits) {
  for (int v = -32768; v <= 32767; ++v) {
    uint8_t b[2];
    const auto w = static_cast<int16_t>(v);
    encode_word(w, b, (v & 1) != 0);
    EXPECT_EQ((b[0] & 0x80) != 0, (v & 1) != 0);
    ASSERT_EQ(b[1] & 0x80, 0);
    ASSERT_EQ(decode_word(b[0], b[1]), quantize_word(w)) << v;
  }
}

TEST(FlockRecord, SizesMatchTheManual) {
  const std::pair<Format, size_t> sizes[] = {{Format::position, 6},
                                             {Format::angles, 6},
                                             {Format::matrix, 18},
                                             {Format::position_angles, 12},
                                             {Format::position_matrix, 24},
                                             {Format::quaternion, 8},
                                             {Format::position_quaternion, 14}};
  for (auto [f, n] : sizes) {
    EXPECT_EQ((RecordLayout{f, false, false}.size()), n) << format_name(f);
    EXPECT_EQ((RecordLayout{f, true, false}.size()), n + 1);
    EXPECT_EQ((RecordLayout{f, true, true}.size()), n + 2);
  }
}

TEST(FlockRecord, FormatCommandsAndCodes) {
  EXPECT_EQ(format_command(Format::position), 'V');
  EXPECT_EQ(format_command(Format::angles), 'W');
  EXPECT_EQ(format_command(Format::matrix), 'X');
  EXPECT_EQ(format_command(Format::position_angles), 'Y');
  EXPECT_EQ(format_command(Format::position_matrix), 'Z');
  EXPECT_EQ(format_command(Format::quaternion), 0x5C);
  EXPECT_EQ(format_command(Format::position_quaternion), 0x5D);
  for (Format f : kAllFormats) {
    EXPECT_EQ(format_from_command(format_command(f)), f);
    EXPECT_EQ(parse_format(format_name(f)), f);
  }
  EXPECT_FALSE(format_from_command('['));  // code 6: factory test, not a record format
  EXPECT_FALSE(parse_format("posquat"));
}

TEST(FlockRecord, WorkedGroupModeExampleFromTheProtocolNotes) {
  // POS/ANGLES in group mode, bird 2: X=+18 in, Y=-9, Z=+4.5 (36 in scale); az 90, el 0, roll -45.
  RawRecord r;
  r.layout = {Format::position_angles, false, true};
  r.words = {0x4000, static_cast<int16_t>(0xE000), 0x1000, 0x4000, 0x0000, static_cast<int16_t>(0xE000)};
  r.address = 2;
  std::array<uint8_t, kMaxRecordSize> buf{};
  const size_t n = encode_record(r, buf);
  const std::vector<uint8_t> expected = {0x80, 0x20, 0x00, 0x70, 0x00, 0x08, 0x00, 0x20, 0x00, 0x00, 0x00, 0x70, 0x02};
  ASSERT_EQ(n, expected.size());
  EXPECT_EQ(std::vector<uint8_t>(buf.begin(), buf.begin() + static_cast<long>(n)), expected);

  auto back = decode_record(std::span<const uint8_t>(buf.data(), n), r.layout);
  ASSERT_TRUE(back);
  const Measurement m = from_raw(*back, PositionRange::in36);
  EXPECT_NEAR(m.position_in.x, 18.0, 1e-9);
  EXPECT_NEAR(m.position_in.y, -9.0, 1e-9);
  EXPECT_NEAR(m.position_in.z, 4.5, 1e-9);
  EXPECT_NEAR(m.angles_deg.x, 90.0, 1e-9);
  EXPECT_NEAR(m.angles_deg.y, 0.0, 1e-9);
  EXPECT_NEAR(m.angles_deg.z, -45.0, 1e-9);
  EXPECT_EQ(m.address, 2);
}

TEST(FlockRecord, RejectsBadPhasing) {
  const RecordLayout l{Format::position, false, false};
  std::vector<uint8_t> good = {0x80, 0, 0, 0, 0, 0};
  EXPECT_TRUE(decode_record(good, l));
  auto no_phase = good;
  no_phase[0] = 0x00;
  EXPECT_FALSE(decode_record(no_phase, l));
  auto extra_phase = good;
  extra_phase[3] = 0x81;
  EXPECT_FALSE(decode_record(extra_phase, l));
  EXPECT_FALSE(decode_record(std::span<const uint8_t>(good.data(), 5), l));
}

TEST(FlockScaling, PositionRanges) {
  RawRecord r;
  r.layout = {Format::position, false, false};
  r.words = {16384, -16384, 32764};
  for (auto [range, full] : {std::pair{PositionRange::in36, 36.0}, std::pair{PositionRange::in72, 72.0},
                             std::pair{PositionRange::in144, 144.0}}) {
    const Measurement m = from_raw(r, range);
    EXPECT_DOUBLE_EQ(m.position_in.x, full / 2);
    EXPECT_DOUBLE_EQ(m.position_in.y, -full / 2);
    EXPECT_NEAR(m.position_in.z, full, full / 8192);
    // Out-of-range positions saturate instead of wrapping.
    Measurement far;
    far.position_in = {full * 3, -full * 3, 0};
    const RawRecord w = to_raw(far, r.layout, range);
    EXPECT_EQ(w.words[0], 32764);
    EXPECT_EQ(w.words[1], -32768);
  }
}

TEST(FlockScaling, AnglesMatrixAndQuaternionUnits) {
  RawRecord a;
  a.layout = {Format::angles, false, false};
  a.words = {-32768, 8192, 16384};  // -180, 45, 90 degrees
  Measurement m = from_raw(a, PositionRange::in36);
  EXPECT_DOUBLE_EQ(m.angles_deg.x, -180.0);
  EXPECT_DOUBLE_EQ(m.angles_deg.y, 45.0);
  EXPECT_DOUBLE_EQ(m.angles_deg.z, 90.0);

  RawRecord q;
  q.layout = {Format::quaternion, false, false};
  q.words = {16384, 16384, 16384, 16384};  // 0.5 each: already unit
  m = from_raw(q, PositionRange::in36);
  EXPECT_NEAR(glm::length(m.quaternion), 1.0, 1e-12);
  EXPECT_NEAR(m.quaternion.w, 0.5, 1e-12);
}

TEST(FlockFrames, MatrixDefinitionMatchesTheManual) {
  const double A = 0.3, E = -0.7, R = 1.1;
  const glm::dmat3 r = transmitter_from_sensor_from_angles(glm::dvec3(A, E, R) * (180.0 / kPi));
  const glm::dmat3 M = glm::transpose(r);  // M(i,j) = M[j-1][i-1] in glm's column-major form
  const double cA = std::cos(A), sA = std::sin(A), cE = std::cos(E), sE = std::sin(E), cR = std::cos(R),
               sR = std::sin(R);
  EXPECT_NEAR(M[0][0], cE * cA, 1e-12);                  // M11
  EXPECT_NEAR(M[1][0], cE * sA, 1e-12);                  // M12
  EXPECT_NEAR(M[2][0], -sE, 1e-12);                      // M13
  EXPECT_NEAR(M[0][1], -cR * sA + sR * sE * cA, 1e-12);  // M21
  EXPECT_NEAR(M[1][1], cR * cA + sR * sE * sA, 1e-12);   // M22
  EXPECT_NEAR(M[2][1], sR * cE, 1e-12);                  // M23
  EXPECT_NEAR(M[0][2], sR * sA + cR * sE * cA, 1e-12);   // M31
  EXPECT_NEAR(M[1][2], -sR * cA + cR * sE * sA, 1e-12);  // M32
  EXPECT_NEAR(M[2][2], cR * cE, 1e-12);                  // M33
  const glm::dvec3 back = angles_from_transmitter_from_sensor(r) * (kPi / 180.0);
  EXPECT_NEAR(back.x, A, 1e-12);
  EXPECT_NEAR(back.y, E, 1e-12);
  EXPECT_NEAR(back.z, R, 1e-12);
}

TEST(FlockFrames, MimicAxesMapping) {
  const glm::dmat3 c = mimic_from_flock();
  EXPECT_NEAR(glm::determinant(c), 1.0, 1e-12);  // proper rotation: handedness kept
  // A sensor 10 in in front of the transmitter and 5 in below it.
  Measurement m;
  m.position_in = {10, 0, 5};
  const SensorSample s = to_sample(m, {Format::position, false, false});
  EXPECT_NEAR(s.position_m.z, 0.254f, 1e-6);   // forward -> +Z
  EXPECT_NEAR(s.position_m.y, -0.127f, 1e-6);  // down -> -Y
  EXPECT_NEAR(s.position_m.x, 0.0f, 1e-6);
  m.position_in = {0, 4, 0};  // the transmitter's right is the performer's right: -X
  EXPECT_NEAR(to_sample(m, {Format::position, false, false}).position_m.x, -0.1016f, 1e-6);

  // Azimuth +90 turns the sensor's forward (+X flock) to the right (+Y flock): in Mimic axes
  // forward +Z goes to -X, a rotation of -90 degrees about +Y.
  const Measurement turned = measurement_from_pose({0, 0, 0}, transmitter_from_sensor_from_angles({90, 0, 0}));
  const SensorSample t = to_sample(turned, {Format::quaternion, false, false});
  const glm::vec3 fwd = t.orientation * glm::vec3(0, 0, 1);
  EXPECT_NEAR(fwd.x, -1.0f, 1e-5);
  EXPECT_NEAR(fwd.y, 0.0f, 1e-5);
  EXPECT_NEAR(fwd.z, 0.0f, 1e-5);
}

// The property: for every format, with and without button and group bytes, a measurement survives
// encode -> bytes -> decode within the 14-bit quantisation, and the words survive exactly.
TEST(FlockRoundTrip, AllFormatsSeeded) {
  std::mt19937_64 rng(20261121);
  std::uniform_real_distribution<double> pos(-0.95, 0.95), unit(-1.0, 1.0);
  for (PositionRange range : {PositionRange::in36, PositionRange::in72, PositionRange::in144}) {
    const double full = full_scale_in(range);
    for (Format f : kAllFormats) {
      for (int opts = 0; opts < 4; ++opts) {
        const RecordLayout layout{f, (opts & 1) != 0, (opts & 2) != 0};
        for (int iter = 0; iter < 300; ++iter) {
          glm::dquat q(unit(rng), unit(rng), unit(rng), unit(rng));
          if (glm::length(q) < 0.1) continue;
          q = glm::normalize(q);
          const glm::dvec3 p(pos(rng) * full, pos(rng) * full, pos(rng) * full);
          Measurement m = measurement_from_pose(p, glm::mat3_cast(q));
          m.button = static_cast<uint8_t>(std::array{0x00, 0x10, 0x30, 0x70}[iter % 4]);
          m.address = static_cast<uint8_t>(1 + iter % 14);

          const RawRecord raw = to_raw(m, layout, range);
          std::array<uint8_t, kMaxRecordSize> buf{};
          const size_t n = encode_record(raw, buf);
          ASSERT_EQ(n, layout.size());
          auto back = decode_record(std::span<const uint8_t>(buf.data(), n), layout);
          ASSERT_TRUE(back);
          for (int i = 0; i < word_count(f); ++i) ASSERT_EQ(back->words[i], raw.words[i]);
          const Measurement d = from_raw(*back, range);
          if (layout.button) {
            EXPECT_EQ(d.button, m.button);
          }
          if (layout.group) {
            EXPECT_EQ(d.address, m.address);
          }
          if (has_position(f)) {
            const double tol = full / 8192 * 0.51;  // half a quantisation step
            ASSERT_NEAR(d.position_in.x, p.x, tol);
            ASSERT_NEAR(d.position_in.y, p.y, tol);
            ASSERT_NEAR(d.position_in.z, p.z, tol);
          }
          if (f != Format::position) {
            // Compare rotations, not angles (angles are singular at elevation ±90).
            const double dot = std::abs(glm::dot(d.quaternion, m.quaternion));
            ASSERT_GT(dot, std::cos(0.5 * 0.004)) << format_name(f);  // within ~0.25 degree
          }
        }
      }
    }
  }
}

TEST(FlockRoundTrip, SampleThroughTheWireInMimicFrame) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (Format f : kAllFormats) {
    for (int iter = 0; iter < 200; ++iter) {
      SensorSample s;
      s.sensor = 3;
      s.position_m = glm::vec3(glm::dvec3(unit(rng), unit(rng), unit(rng)) * 0.8);
      s.orientation = glm::normalize(glm::quat(float(unit(rng)), float(unit(rng)), float(unit(rng)), float(unit(rng))));
      const RecordLayout layout{f, false, true};
      const RawRecord raw = to_raw(measurement_from_sample(s), layout, PositionRange::in36);
      std::array<uint8_t, kMaxRecordSize> buf{};
      const size_t n = encode_record(raw, buf);
      const SensorSample d = to_sample(from_raw(*decode_record({buf.data(), n}, layout), PositionRange::in36), layout);
      EXPECT_EQ(d.sensor, 3);
      if (has_position(f)) {
        EXPECT_LT(glm::length(d.position_m - s.position_m), 0.0003f);
      }
      if (f != Format::position) {
        EXPECT_GT(std::abs(glm::dot(d.orientation, s.orientation)), 0.99999f);
      }
    }
  }
}

TEST(FlockCommands, Encoders) {
  std::vector<uint8_t> out;
  append_examine(out, param::kStatus);
  EXPECT_EQ(out, (std::vector<uint8_t>{'O', 0}));
  out.clear();
  append_examine(out, param::kFlockStatus, 3);
  EXPECT_EQ(out, (std::vector<uint8_t>{0xF3, 'O', 36}));
  out.clear();
  append_group_mode(out, true);
  EXPECT_EQ(out, (std::vector<uint8_t>{'P', 35, 1}));
  out.clear();
  append_auto_config(out, 5);
  EXPECT_EQ(out, (std::vector<uint8_t>{'P', 50, 5}));
  out.clear();
  append_format(out, Format::position_quaternion, 2);
  append_hemisphere(out, Hemisphere::lower, 2);
  EXPECT_EQ(out, (std::vector<uint8_t>{0xF2, ']', 0xF2, 'L', 0x0C, 0x00}));
  out.clear();
  append_change_word(out, param::kMeasurementRateCount, 5862);
  EXPECT_EQ(out, (std::vector<uint8_t>{'P', 6, 0xE6, 0x16}));
  out.clear();
  append_button_mode(out, true, 1);
  EXPECT_EQ(out, (std::vector<uint8_t>{0xF1, 'M', 1}));

  EXPECT_EQ(fbb_prefix(0), 0xF0);
  EXPECT_EQ(fbb_prefix(14), 0xFE);
  EXPECT_EQ(fbb_prefix(16), 0xE0);
  EXPECT_EQ(fbb_prefix(30), 0xEE);
  for (int a = 0; a <= 30; ++a) EXPECT_EQ(fbb_prefix_address(fbb_prefix(a)), a);
  EXPECT_EQ(fbb_prefix_address('B'), -1);

  EXPECT_EQ(report_rate_command(1), 'Q');
  EXPECT_EQ(report_rate_command(32), 'T');
  EXPECT_FALSE(report_rate_command(4));
  for (int n : {1, 2, 8, 32}) EXPECT_EQ(report_rate_divisor(*report_rate_command(n)), n);
}

TEST(FlockCommands, HemisphereBytes) {
  for (Hemisphere h : {Hemisphere::forward, Hemisphere::aft, Hemisphere::upper, Hemisphere::lower, Hemisphere::left,
                       Hemisphere::right}) {
    const auto b = hemisphere_bytes(h);
    EXPECT_EQ(hemisphere_from_bytes(b[0], b[1]), h);
    EXPECT_EQ(parse_hemisphere(hemisphere_name(h)), h);
  }
  EXPECT_EQ(hemisphere_bytes(Hemisphere::lower), (std::array<uint8_t, 2>{0x0C, 0x00}));
  EXPECT_TRUE(in_hemisphere(Hemisphere::lower, {0, 0, 3}));
  EXPECT_FALSE(in_hemisphere(Hemisphere::lower, {0, 0, -3}));
  EXPECT_TRUE(in_hemisphere(Hemisphere::right, {0, 1, 0}));
}

TEST(FlockParameters, SizesStatusRatesRevision) {
  EXPECT_EQ(examine_size(param::kStatus), 2);
  EXPECT_EQ(examine_size(param::kSystemModel), 10);
  EXPECT_EQ(examine_size(param::kFlockStatus), 14);
  EXPECT_EQ(examine_size(param::kAutoConfig), 5);
  EXPECT_EQ(examine_size(param::kErrorCode), 1);
  EXPECT_EQ(examine_size(200), 0);
  EXPECT_EQ(change_size(param::kGroupMode), 1);
  EXPECT_EQ(change_size(param::kStatus), 0);  // read-only
  EXPECT_EQ(change_size(param::kHemisphere), 2);

  BirdStatus s;
  s.master = true;
  s.running = true;
  s.initialized = true;
  s.streaming = true;
  s.format = Format::position_quaternion;
  const uint16_t w = encode_status(s);
  EXPECT_EQ(w, 0xD011);
  const BirdStatus d = decode_status(w);
  EXPECT_TRUE(d.master && d.running && d.initialized && d.streaming && !d.sleeping);
  EXPECT_EQ(d.format, Format::position_quaternion);

  // The manual's example: 103.3 Hz is C = 5862 at 20 MHz and 7328 at 25 MHz.
  EXPECT_NEAR(measurement_rate_count(103.3, 20.0), 5862, 2);
  EXPECT_NEAR(measurement_rate_count(103.3, 25.0), 7328, 2);
  EXPECT_NEAR(measurement_rate_hz(7328, 25.0), 103.3, 0.05);
  EXPECT_EQ(software_revision_text(0x4303), "3.67");
  EXPECT_STREQ(error_name(6), "invalid RS232 command");
  EXPECT_STREQ(error_name(99), "unknown error");
}

}  // namespace
}  // namespace mimic::devices::flock::flock_packet_test
