#include "mimic/core/crc32.h"
#include "mimic/sim/log.h"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <gtest/gtest.h>

#include "mimic/core/alloc_counter.h"
#include "mimic/core/file.h"
#include "mimic/sim/sensor_rig.h"
#include "test_data.h"
#include "test_motion.h"

namespace mimic::sim::log_test {
namespace {

namespace fs = std::filesystem;
using devices::SensorSample;

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("mimic_log_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return (dir / name).string();
}

std::vector<uint8_t> bytes_of(const std::string& path) {
  const auto text = read_file(path).value();
  return std::vector<uint8_t>(text.begin(), text.end());
}

bool same_bits(const SensorSample& a, const SensorSample& b) {
  return a.sensor == b.sensor && a.flags == b.flags && a.buttons == b.buttons &&
         std::memcmp(&a.device_time_s, &b.device_time_s, sizeof(double)) == 0 &&
         std::memcmp(&a.host_time_s, &b.host_time_s, sizeof(double)) == 0 &&
         std::memcmp(&a.position_m, &b.position_m, sizeof(a.position_m)) == 0 &&
         std::memcmp(&a.orientation, &b.orientation, sizeof(a.orientation)) == 0;
}

LogHeader sample_header() {
  LogHeader h;
  h.source = "sim:walk?sensors=3&seed=9";
  h.device = "virtual body, 3 sensors";
  h.description = "unit test \"quoted\" \xc3\xa9";
  h.seed = 0xFFFFFFFFFFFFFFF1ull;
  h.rate_hz = 103.3;
  h.world_from_reference.translation = {0.1f, -2.5f, 1e-7f};
  h.world_from_reference.rotation = glm::normalize(glm::quat(0.9f, 0.1f, -0.3f, 0.2f));
  h.calibration_json = R"({"offsets": [1, 2, 3]})";
  for (uint16_t i = 0; i < 3; ++i) {
    LogSensor s;
    s.id = static_cast<uint16_t>(i * 7);
    s.name = "sensor" + std::to_string(i);
    s.segment = i == 1 ? "" : "l_wrist";
    s.segment_from_sensor.translation = {0.01f * i, 0.3f, -0.7f};
    s.segment_from_sensor.rotation = glm::normalize(glm::quat(1.0f, 0.0f, 0.1f * i, 0.0f));
    h.sensors.push_back(s);
  }
  return h;
}

std::vector<SensorSample> awkward_samples() {
  std::vector<SensorSample> v;
  for (int i = 0; i < 40; ++i) {
    SensorSample s;
    s.sensor = static_cast<uint16_t>(i % 3 == 2 ? 65535 : i % 3);
    s.device_time_s = i * 0.01 + 1e-13;
    s.host_time_s = 1e6 + i * 0.0097;
    const float f = static_cast<float>(i);
    s.position_m = {std::sin(f), -0.0f, 1e-30f * f};
    s.orientation = glm::normalize(glm::quat(1.0f, 0.01f * f, -0.2f, 0.3f));
    s.buttons = static_cast<uint32_t>(i) << 20;
    s.flags = i % 5 == 0 ? devices::kSampleStale : devices::kSampleValid | devices::kSampleButton;
    v.push_back(s);
  }
  v[7].position_m.x = std::numeric_limits<float>::quiet_NaN();
  v[8].host_time_s = std::numeric_limits<double>::infinity();
  return v;
}

void expect_same_header(const LogHeader& a, const LogHeader& b) {
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.device, b.device);
  EXPECT_EQ(a.description, b.description);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.rate_hz, b.rate_hz);
  EXPECT_EQ(a.calibration_json, b.calibration_json);
  EXPECT_EQ(a.world_from_reference.translation, b.world_from_reference.translation);
  EXPECT_EQ(a.world_from_reference.rotation, b.world_from_reference.rotation);
  ASSERT_EQ(a.sensors.size(), b.sensors.size());
  for (size_t i = 0; i < a.sensors.size(); ++i) {
    EXPECT_EQ(a.sensors[i].id, b.sensors[i].id);
    EXPECT_EQ(a.sensors[i].name, b.sensors[i].name);
    EXPECT_EQ(a.sensors[i].segment, b.sensors[i].segment);
    EXPECT_EQ(a.sensors[i].segment_from_sensor.translation, b.sensors[i].segment_from_sensor.translation);
    EXPECT_EQ(a.sensors[i].segment_from_sensor.rotation, b.sensors[i].segment_from_sensor.rotation);
  }
}

TEST(LogWriter, RoundTripIsBitExact) {
  const std::string path = temp_path("round_trip.mlog");
  const LogHeader header = sample_header();
  const auto samples = awkward_samples();
  const std::vector<uint8_t> raw1 = {0x00, 0xFF, 0x80, 0x0D}, raw2 = {};
  {
    auto w = LogWriter::create(path, header).value();
    for (size_t i = 0; i < samples.size(); ++i) {
      if (i == 3) {
        ASSERT_TRUE(w.append_raw(1.5, RawDirection::to_device, raw1));
      }
      if (i == 10) {
        ASSERT_TRUE(w.append_raw(2.5, RawDirection::from_device, raw2));
      }
      ASSERT_TRUE(w.append(samples[i]));
    }
    ASSERT_TRUE(w.close());
    EXPECT_EQ(w.samples_written(), samples.size());
    EXPECT_EQ(w.bytes_written(), fs::file_size(path));
  }
  EXPECT_FALSE(fs::exists(path + ".part"));
  auto log = read_log(path);
  ASSERT_TRUE(log) << log.error().what();
  EXPECT_TRUE(log->complete);
  EXPECT_FALSE(log->damage);
  expect_same_header(log->header, header);
  ASSERT_EQ(log->samples.size(), samples.size());
  for (size_t i = 0; i < samples.size(); ++i) EXPECT_TRUE(same_bits(log->samples[i], samples[i])) << i;
  ASSERT_EQ(log->raw.size(), 2u);
  EXPECT_EQ(log->raw[0].bytes, raw1);
  EXPECT_EQ(log->raw[0].samples_before, 3u);
  EXPECT_EQ(log->raw[0].direction, RawDirection::to_device);
  EXPECT_EQ(log->raw[0].host_time_s, 1.5);
  EXPECT_EQ(log->raw[1].bytes, raw2);
  EXPECT_EQ(log->raw[1].samples_before, 10u);
  EXPECT_EQ(log->records, 1 + samples.size() + 2 + 1);

  // The writer emits exactly what the encoders describe.
  std::vector<uint8_t> expect;
  encode_log_prefix(header, expect);
  for (size_t i = 0; i < samples.size(); ++i) {
    if (i == 3) encode_raw_record(1.5, RawDirection::to_device, raw1, expect);
    if (i == 10) encode_raw_record(2.5, RawDirection::from_device, raw2, expect);
    encode_sample_record(samples[i], expect);
  }
  encode_end_record(samples.size(), expect);
  EXPECT_EQ(bytes_of(path), expect);
}

TEST(LogWriter, HeaderIsOnDiskAtOnceAndRecordsFollowOnFlush) {
  const std::string path = temp_path("flush.mlog");
  LogWriterOptions opt;
  opt.flush_interval_s = 0.5;
  auto w = LogWriter::create(path, sample_header(), opt).value();
  auto log = read_log(path);
  ASSERT_TRUE(log) << "the header must be complete as soon as the file exists";
  EXPECT_EQ(log->samples.size(), 0u);
  EXPECT_FALSE(log->complete);
  ASSERT_TRUE(log->damage);
  EXPECT_NE(log->damage->reason.find("without an end record"), std::string::npos);

  SensorSample s;
  const uint64_t before = thread_allocation_count();
  for (int i = 0; i < 40; ++i) {  // 0.39 s of host time: below the flush interval
    s.host_time_s = 10.0 + i * 0.01;
    ASSERT_TRUE(w.append(s));
  }
  EXPECT_EQ(thread_allocation_count(), before) << "append allocated";
  EXPECT_EQ(read_log(path)->samples.size(), 0u);
  s.host_time_s = 10.5;
  ASSERT_TRUE(w.append(s));  // half a second after the first: due
  log = read_log(path);
  EXPECT_EQ(log->samples.size(), 41u);
  EXPECT_FALSE(log->complete);
  ASSERT_TRUE(w.append(s));
  ASSERT_TRUE(w.flush());
  EXPECT_EQ(read_log(path)->samples.size(), 42u);
  ASSERT_TRUE(w.close());
  EXPECT_TRUE(read_log(path)->complete);
  EXPECT_FALSE(w.append(s)) << "append after close must fail";
}

TEST(LogWriter, SmallBufferFlushesByVolume) {
  const std::string path = temp_path("volume.mlog");
  LogWriterOptions opt;
  opt.flush_interval_s = 1e9;
  opt.buffer_bytes = 1000;
  auto w = LogWriter::create(path, sample_header(), opt).value();
  SensorSample s;
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(w.append(s));
  const size_t on_disk = read_log(path)->samples.size();
  EXPECT_GE(on_disk, 100u - 1000u / 63u - 1u);
  EXPECT_LT(on_disk, 100u);
}

TEST(LogWriter, UnwritablePathIsAClearError) {
  auto w = LogWriter::create("/nonexistent-dir/x.mlog", sample_header());
  ASSERT_FALSE(w);
  EXPECT_EQ(w.error().code, Errc::io_error);
  EXPECT_NE(w.error().message.find("/nonexistent-dir/x.mlog"), std::string::npos);
}

struct SmallLog {
  std::vector<uint8_t> bytes;
  std::vector<size_t> record_ends;  // end offset of every record (header first)
  std::vector<SensorSample> samples;
  std::vector<int> samples_after;  // samples complete once record k is complete
};

SmallLog small_log() {
  SmallLog s;
  LogHeader h;
  h.source = "sim:x";
  h.sensors = {{0, "a", "head", {}}};
  encode_log_prefix(h, s.bytes);
  s.record_ends.push_back(s.bytes.size());
  s.samples_after.push_back(0);
  int n = 0;
  for (int i = 0; i < 6; ++i) {
    if (i == 2) {
      const uint8_t raw[] = {1, 2, 3};
      encode_raw_record(0.5, RawDirection::from_device, raw, s.bytes);
      s.record_ends.push_back(s.bytes.size());
      s.samples_after.push_back(n);
    }
    SensorSample x;
    x.host_time_s = i;
    x.position_m = {float(i), 2, 3};
    s.samples.push_back(x);
    encode_sample_record(x, s.bytes);
    s.record_ends.push_back(s.bytes.size());
    s.samples_after.push_back(++n);
  }
  encode_end_record(6, s.bytes);
  s.record_ends.push_back(s.bytes.size());
  s.samples_after.push_back(n);
  return s;
}

TEST(LogReader, TruncationAtEveryByteKeepsTheCompletePrefix) {
  const SmallLog s = small_log();
  const size_t header_end = s.record_ends[0];
  for (size_t len = 0; len <= s.bytes.size(); ++len) {
    auto log = decode_log(std::span<const uint8_t>(s.bytes.data(), len));
    if (len < header_end) {
      ASSERT_FALSE(log) << "length " << len;
      EXPECT_EQ(log.error().code, Errc::parse_error);
      continue;
    }
    ASSERT_TRUE(log) << "length " << len << ": " << log.error().what();
    // Records wholly inside the prefix survive; the first one cut short is where it stops.
    size_t complete_records = 0;
    while (complete_records < s.record_ends.size() && s.record_ends[complete_records] <= len) ++complete_records;
    const size_t stop_offset = s.record_ends[complete_records - 1];
    EXPECT_EQ(log->samples.size(), static_cast<size_t>(s.samples_after[complete_records - 1])) << "length " << len;
    for (size_t i = 0; i < log->samples.size(); ++i) EXPECT_TRUE(same_bits(log->samples[i], s.samples[i]));
    if (len == s.bytes.size()) {
      EXPECT_TRUE(log->complete);
      EXPECT_FALSE(log->damage);
    } else {
      EXPECT_FALSE(log->complete);
      ASSERT_TRUE(log->damage) << "length " << len;
      EXPECT_EQ(log->damage->byte_offset, stop_offset) << "length " << len;
      EXPECT_EQ(log->damage->record_index, complete_records) << "length " << len;
      EXPECT_NE(log->damage->what().find("byte " + std::to_string(stop_offset)), std::string::npos);
    }
  }
}

TEST(LogReader, CorruptedByteIsCaughtByTheCrcAndEveryOtherRecordSurvives) {
  const SmallLog s = small_log();
  const size_t last = s.record_ends.size() - 1;  // the end record
  for (size_t at = 0; at < s.bytes.size(); ++at) {
    for (uint8_t mask : {uint8_t{0x01}, uint8_t{0x80}}) {
      std::vector<uint8_t> bad = s.bytes;
      bad[at] ^= mask;
      auto log = decode_log(bad);
      if (at < s.record_ends[0]) {
        EXPECT_FALSE(log) << "header byte " << at << " corrupted but accepted";
        continue;
      }
      ASSERT_TRUE(log) << at;
      size_t rec = 0;
      while (s.record_ends[rec] <= at) ++rec;  // the record holding the bad byte
      ASSERT_TRUE(log->damage) << at;
      EXPECT_EQ(log->damage->byte_offset, s.record_ends[rec - 1]) << at;
      EXPECT_EQ(log->damage->record_index, rec) << at;
      ASSERT_EQ(log->damages.size(), 1u) << at << ": " << log->damage->what();
      // Exactly the damaged record is skipped; reading resumes at the next one.
      EXPECT_EQ(log->damage->bytes_skipped, s.record_ends[rec] - s.record_ends[rec - 1]) << at;
      const bool was_sample = s.samples_after[rec] != s.samples_after[rec - 1];
      EXPECT_EQ(log->samples.size(), s.samples.size() - (was_sample ? 1 : 0)) << at;
      EXPECT_EQ(log->complete, rec != last) << at;
      if (rec != last) {
        EXPECT_TRUE(log->damage->resumed) << at;
        EXPECT_EQ(log->damage->resumed_at_byte, s.record_ends[rec]) << at;
        EXPECT_EQ(log->samples_lost, was_sample ? 1u : 0u) << at;
      }
      size_t k = 0;
      for (size_t i = 0; i < s.samples.size(); ++i) {
        if (was_sample && i == size_t(s.samples_after[rec - 1])) continue;  // the lost one
        ASSERT_LT(k, log->samples.size());
        EXPECT_TRUE(same_bits(log->samples[k++], s.samples[i])) << at << " sample " << i;
      }
    }
  }
}

// A long recording with one flipped bit in the middle keeps everything but the one record, and a
// stretch of garbage costs only the records it covers; both are reported with where and how much.
TEST(LogReader, ResynchronisesAfterDamageInTheMiddle) {
  LogHeader h;
  h.source = "sim:x";
  h.sensors = {{0, "a", "head", {}}};
  std::vector<uint8_t> bytes;
  encode_log_prefix(h, bytes);
  const size_t first_sample = bytes.size();
  constexpr size_t kSamples = 10000;
  for (size_t i = 0; i < kSamples; ++i) {
    SensorSample x;
    x.host_time_s = double(i) * 0.01;
    x.position_m = {float(i), 1, 2};
    encode_sample_record(x, bytes);
  }
  encode_end_record(kSamples, bytes);
  constexpr size_t kRecord = 63;

  std::vector<uint8_t> flipped = bytes;
  const size_t mid = first_sample + kSamples / 2 * kRecord + 30;
  flipped[mid] ^= 0x10;
  auto one = decode_log(flipped);
  ASSERT_TRUE(one);
  EXPECT_TRUE(one->complete);
  EXPECT_GE(one->samples.size(), kSamples * 99 / 100);
  EXPECT_EQ(one->samples.size(), kSamples - 1);
  EXPECT_EQ(one->samples_lost, 1u);
  ASSERT_EQ(one->damages.size(), 1u);
  EXPECT_EQ(one->damages[0].byte_offset, first_sample + kSamples / 2 * kRecord);
  EXPECT_EQ(one->damages[0].bytes_skipped, kRecord);
  EXPECT_EQ(one->damages[0].samples_before, kSamples / 2);
  EXPECT_NE(one->damages[0].what().find("63 bytes skipped, reading resumed at byte " +
                                        std::to_string(first_sample + (kSamples / 2 + 1) * kRecord)),
            std::string::npos)
      << one->damages[0].what();
  EXPECT_EQ(one->samples.back().position_m.x, float(kSamples - 1));

  // Two damaged stretches: 1,000 bytes of garbage, and a length field made implausible.
  std::vector<uint8_t> garbage = bytes;
  const size_t g = first_sample + 1000 * kRecord + 17;
  for (size_t i = 0; i < 1000; ++i) garbage[g + i] = uint8_t(i * 37 + 11);
  const size_t l = first_sample + 7000 * kRecord;
  garbage[l + 3] = 0x7F;
  auto two = decode_log(garbage);
  ASSERT_TRUE(two);
  EXPECT_TRUE(two->complete);
  ASSERT_EQ(two->damages.size(), 2u);
  EXPECT_EQ(two->damages[0].byte_offset, first_sample + 1000 * kRecord);
  EXPECT_EQ(two->damages[1].byte_offset, l);
  EXPECT_EQ(two->damages[1].bytes_skipped, kRecord);
  const size_t lost = (1000 + 17 + kRecord - 1) / kRecord + 1;  // records the garbage touched, and one
  EXPECT_EQ(two->samples_lost, lost);
  EXPECT_EQ(two->samples.size(), kSamples - lost);
  EXPECT_EQ(two->bytes_skipped, two->damages[0].bytes_skipped + kRecord);
}

TEST(LogReader, RejectsForeignAndFutureFiles) {
  auto bad = decode_log(std::vector<uint8_t>{'B', 'V', 'H', '\n'});
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("not a Mimic log"), std::string::npos);
  std::vector<uint8_t> v = small_log().bytes;
  v[8] = 2;
  auto future = decode_log(v);
  ASSERT_FALSE(future);
  EXPECT_EQ(future.error().code, Errc::unsupported);
  auto empty = decode_log({});
  ASSERT_FALSE(empty);
  EXPECT_NE(empty.error().message.find("empty"), std::string::npos) << empty.error().message;
  auto missing = read_log(temp_path("missing.mlog"));
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::io_error);
  EXPECT_NE(missing.error().message.find("missing.mlog"), std::string::npos);
}

// A header whose CRC is right but whose "format" is not a string: refused, never thrown.
TEST(LogReader, HeaderOfTheWrongShapeIsRefusedWithAReason) {
  for (const std::string text : {R"({"format": 1, "sensors": []})", R"({"format": ["mimic-log"]})", R"([1, 2])"}) {
    std::vector<uint8_t> v{0x89, 'M', 'L', 'G', '\r', '\n', 0x1A, '\n', 1, 0, 0, 0};
    const size_t start = v.size();
    const uint32_t len = static_cast<uint32_t>(text.size());
    for (int i = 0; i < 4; ++i) v.push_back(static_cast<uint8_t>(len >> (8 * i)));
    v.push_back(1);  // header record
    v.insert(v.end(), text.begin(), text.end());
    const uint32_t crc = crc32(std::span<const uint8_t>(v.data() + start, v.size() - start));
    for (int i = 0; i < 4; ++i) v.push_back(static_cast<uint8_t>(crc >> (8 * i)));
    auto log = decode_log(v);
    ASSERT_FALSE(log) << text;
    EXPECT_EQ(log.error().code, Errc::parse_error) << text;
    EXPECT_NE(log.error().message.find("not a mimic-log header"), std::string::npos) << log.error().message;
  }
}

TEST(LogReader, EndRecordMustCountTheSamples) {
  SmallLog s = small_log();
  std::vector<uint8_t> v(s.bytes.begin(), s.bytes.begin() + static_cast<long>(s.record_ends[s.record_ends.size() - 2]));
  encode_end_record(99, v);
  auto log = decode_log(v);
  ASSERT_TRUE(log);
  EXPECT_FALSE(log->complete);
  ASSERT_TRUE(log->damage);
  EXPECT_NE(log->damage->reason.find("99"), std::string::npos);
  EXPECT_EQ(log->samples.size(), 6u);
}

// Bytes after the end record are not read as records, but they are reported with the offset
// where they start: a log never hides what it carries.
TEST(LogReader, BytesAfterTheEndRecordAreReportedWithTheirOffset) {
  SmallLog s = small_log();
  std::vector<uint8_t> v = s.bytes;
  const size_t end = v.size();
  for (const char c : std::string("\x1b[31mtrailing garbage")) v.push_back(static_cast<uint8_t>(c));
  auto log = decode_log(v);
  ASSERT_TRUE(log);
  EXPECT_TRUE(log->complete);
  EXPECT_EQ(log->samples.size(), 6u);
  EXPECT_EQ(log->samples_lost, 0u);
  ASSERT_TRUE(log->damage);
  EXPECT_EQ(log->damage->byte_offset, end);
  EXPECT_EQ(log->damage->bytes_skipped, v.size() - end);
  EXPECT_NE(log->damage->what().find("after the end record"), std::string::npos) << log->damage->what();
  EXPECT_NE(log->damage->what().find("byte " + std::to_string(end)), std::string::npos) << log->damage->what();
  // A sound log reports nothing.
  EXPECT_FALSE(decode_log(s.bytes)->damage);
}

TEST(SampleCsv, OneLinePerSampleWithSixDecimals) {
  SensorSample s;
  s.host_time_s = 12.3456789;
  s.sensor = 4;
  s.position_m = {0.5f, -1.25f, 0.0f};
  s.orientation = glm::quat(1, 0, 0, 0);
  char buf[160];
  const size_t n = format_sample_csv(s, buf);
  EXPECT_EQ(std::string(buf, n), "12.345679,4,0.500000,-1.250000,0.000000,1.000000,0.000000,0.000000,0.000000\n");
}

// ---- golden logs (tests/data/logs) ----
//
// golden_v1.mlog is a version-1 log written by this code on a fixed seed; golden_v1.csv is its
// CSV dump. Old logs must stay readable, so the file is never regenerated silently: run
//   MIMIC_REGENERATE_GOLDEN=1 ./build/bin/mimic_sim_tests --gtest_filter='GoldenLog.*'
// and review the diff (git diff --stat tests/data/logs; the CSV is human-readable).

fs::path golden_dir() { return mimic::test::repo_test_data("logs"); }

std::vector<uint8_t> make_golden_log() {
  const auto motion = test::swing_motion();
  RigConfig c;
  c.sensors = make_layout("3", motion->skeleton()).value();
  c.rate_hz = 50;
  c.position_noise_mm = 2;
  c.orientation_noise_deg = 1;
  c.latency_s = 0.01;
  c.dropout_probability = 0.1;
  c.dropout_burst = 2;
  c.seed = 2026;
  auto rig = SensorRig::create(motion, c).value();
  LogHeader h;
  h.source = "sim:swing?sensors=3&rate=50&noise_mm=2&noise_deg=1&latency_ms=10&dropout=0.1&seed=2026";
  h.device = "virtual body (test motion 'swing'), 3 sensors";
  h.description = "golden log, format version 1";
  h.seed = c.seed;
  h.rate_hz = c.rate_hz;
  for (size_t i = 0; i < c.sensors.size(); ++i)
    h.sensors.push_back(
        {static_cast<uint16_t>(i), c.sensors[i].name, c.sensors[i].segment, c.sensors[i].segment_from_sensor});
  std::vector<uint8_t> out;
  encode_log_prefix(h, out);
  std::vector<SensorSample> tick(3);
  for (int k = 0; k < 8; ++k) {
    rig.step(tick);
    if (k == 4) {
      const uint8_t cmd[] = {'B', '@'};
      encode_raw_record(0.085, RawDirection::to_device, cmd, out);
    }
    for (const auto& s : tick) encode_sample_record(s, out);
  }
  encode_end_record(24, out);
  return out;
}

std::string csv_of(const LogContents& log) {
  std::string text;
  char buf[160];
  for (const auto& s : log.samples) text.append(buf, format_sample_csv(s, buf));
  return text;
}

TEST(GoldenLog, VersionOneLogStillReadsTheSame) {
  const fs::path mlog = golden_dir() / "golden_v1.mlog", csv = golden_dir() / "golden_v1.csv";
  if (std::getenv("MIMIC_REGENERATE_GOLDEN")) {
    const auto bytes = make_golden_log();
    ASSERT_TRUE(
        write_file_atomic(mlog.string(), std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size())));
    ASSERT_TRUE(write_file_atomic(csv.string(), csv_of(decode_log(bytes).value())));
  }
  auto log = read_log(mlog.string());
  ASSERT_TRUE(log) << log.error().what();
  EXPECT_TRUE(log->complete);
  EXPECT_EQ(log->header.seed, 2026u);
  EXPECT_EQ(log->header.rate_hz, 50.0);
  ASSERT_EQ(log->header.sensors.size(), 3u);
  EXPECT_EQ(log->header.sensors[1].name, "l_hand");
  EXPECT_EQ(log->header.sensors[1].segment, "l_wrist");
  ASSERT_EQ(log->samples.size(), 24u);
  ASSERT_EQ(log->raw.size(), 1u);
  EXPECT_EQ(log->raw[0].samples_before, 12u);
  EXPECT_EQ(csv_of(*log), read_file(csv.string()).value());

  // Today's rig and encoder still produce the same session (within float noise: the golden
  // bytes came from this machine's libm).
  auto fresh = decode_log(make_golden_log()).value();
  ASSERT_EQ(fresh.samples.size(), log->samples.size());
  for (size_t i = 0; i < fresh.samples.size(); ++i) {
    EXPECT_EQ(fresh.samples[i].flags, log->samples[i].flags) << i;
    EXPECT_NEAR(fresh.samples[i].host_time_s, log->samples[i].host_time_s, 1e-12);
    EXPECT_LT(glm::length(fresh.samples[i].position_m - log->samples[i].position_m), 1e-6f) << i;
    EXPECT_GT(std::abs(glm::dot(fresh.samples[i].orientation, log->samples[i].orientation)), 1.0f - 1e-6f) << i;
  }
}

}  // namespace
}  // namespace mimic::sim::log_test
