// Raw device sessions: the bytes a driver exchanged, kept through the log, played back to the
// real driver by a recorded device on a pty — the same samples come out, and a changed byte
// shows.
#include <gtest/gtest.h>

#include <filesystem>

#include "flock_test_support.h"
#include "mimic/devices/flock.h"
#include "mimic/sim/raw_session.h"
#include "mimic/sim/virtual_flock.h"

namespace mimic::sim::raw_session_test {
namespace {

std::string take(SerialDevice& d, double now_s) {
  uint8_t buf[256];
  const size_t n = d.take_output(now_s, buf);
  return std::string(reinterpret_cast<const char*>(buf), n);
}

RawChunk chunk(double t, RawDirection dir, const std::string& text) {
  return RawChunk{t, dir, 0, std::vector<uint8_t>(text.begin(), text.end())};
}

// What the device said before the host spoke goes out at once; an answer waits for its
// question, then for as long as it took in the recording; the stream keeps its pace.
TEST(RecordedSerialDevice, AnswersOnlyAfterTheQuestionAtTheRecordedDelay) {
  RecordedSerialDevice d({chunk(10.0, RawDirection::from_device, "boot"), chunk(10.5, RawDirection::to_device, "Q?"),
                          chunk(10.6, RawDirection::from_device, "A!"), chunk(10.8, RawDirection::from_device, "s1"),
                          chunk(11.0, RawDirection::from_device, "s2")},
                         0);
  EXPECT_EQ(d.bytes_to_send(), 10u);
  d.host_opened(1.0);
  d.advance(1.0);
  EXPECT_EQ(take(d, 1.0), "boot");
  d.advance(5.0);  // the host has not asked yet: nothing, however long
  EXPECT_EQ(take(d, 5.0), "");
  d.receive(std::vector<uint8_t>{'Q'}, 5.0);
  d.advance(5.5);
  EXPECT_EQ(take(d, 5.5), "");  // half a question is no question
  d.receive(std::vector<uint8_t>{'?'}, 6.0);
  d.advance(6.05);
  EXPECT_EQ(take(d, 6.05), "");  // 0.1 s after the question in the recording
  d.advance(6.11);
  EXPECT_EQ(take(d, 6.11), "A!");
  d.advance(6.25);
  EXPECT_EQ(take(d, 6.25), "");
  d.advance(6.31);
  EXPECT_EQ(take(d, 6.31), "s1");
  d.advance(6.51);
  EXPECT_EQ(take(d, 6.51), "s2");
}

TEST(RawByteRecorder, KeepsBothDirectionsInOrderThroughTheLog) {
  RawByteRecorder rec;
  const std::vector<uint8_t> a{1, 2}, b{3}, c{4, 5, 6};
  rec.on_bytes(false, a, 1.0);
  rec.on_bytes(true, b, 1.1);
  rec.on_bytes(true, c, 1.1005);  // the same burst: one chunk
  EXPECT_EQ(rec.bytes_seen(), 6u);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("raw_rec_" + std::to_string(::getpid()) + ".mlog")).string();
  LogHeader h;
  h.source = "flock:/dev/null";
  h.sensors.push_back({1, "bird1", "", {}});
  auto w = LogWriter::create(path, h);
  ASSERT_TRUE(w) << w.error().what();
  auto n = rec.write_to(*w);
  ASSERT_TRUE(n);
  EXPECT_EQ(*n, 2u);
  EXPECT_EQ(*rec.write_to(*w), 0u);  // nothing new
  ASSERT_TRUE(w->close());
  auto log = read_log(path);
  ASSERT_TRUE(log) << log.error().what();
  ASSERT_EQ(log->raw.size(), 2u);
  EXPECT_EQ(log->raw[0].direction, RawDirection::to_device);
  EXPECT_EQ(log->raw[0].bytes, a);
  EXPECT_EQ(log->raw[1].direction, RawDirection::from_device);
  EXPECT_EQ(log->raw[1].bytes, (std::vector<uint8_t>{3, 4, 5, 6}));
  std::filesystem::remove(path);
}

// A Flock session (start-up and stream of three moving birds) recorded byte for byte, then
// played to a new driver: the same samples in the same order. A single changed byte in the
// stream changes what the driver decodes.
TEST(RecordedSerialDevice, ReplaysAFlockSessionToTheDriverSampleForSample) {
  VirtualFlockConfig sc = test::fast_sim(3);
  sc.provider = {};  // the built-in motion: every sample differs
  auto flock = VirtualFlock::create(sc);
  ASSERT_TRUE(flock) << flock.error().what();
  ASSERT_TRUE((*flock)->start());
  auto tap = std::make_shared<RawByteRecorder>();
  devices::FlockConfig dc = test::fast_driver((*flock)->slave_path(), 3);
  dc.tap = tap;
  std::vector<devices::SensorSample> recorded;
  std::vector<RawChunk> raw;
  {
    devices::FlockSource driver(dc);
    ASSERT_TRUE(driver.start());
    recorded = test::collect(driver, 90);
    driver.stop();
  }
  (*flock)->stop();
  ASSERT_GE(recorded.size(), 90u);
  {
    const std::string path =
        (std::filesystem::temp_directory_path() / ("raw_flock_" + std::to_string(::getpid()) + ".mlog")).string();
    LogHeader h;
    h.source = "flock:x?birds=3";
    h.sensors.push_back({1, "bird1", "", {}});
    auto w = LogWriter::create(path, h);
    ASSERT_TRUE(w);
    ASSERT_TRUE(tap->write_to(*w));
    ASSERT_TRUE(w->close());
    auto log = read_log(path);
    ASSERT_TRUE(log);
    raw = log->raw;
    std::filesystem::remove(path);
  }
  ASSERT_GT(raw.size(), 10u);

  auto replay = [&](std::vector<RawChunk> chunks) {
    auto device = std::make_unique<RecordedSerialDevice>(std::move(chunks), 115200);
    const uint64_t to_send = device->bytes_to_send();
    auto server = PtyServer::start(std::move(device));
    EXPECT_TRUE(server) << server.error().what();
    devices::FlockConfig rc = test::fast_driver((*server)->path(), 3);
    devices::FlockSource driver(rc);
    auto st = driver.start();
    EXPECT_TRUE(st) << st.error().what();
    std::vector<devices::SensorSample> got, buf(64);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < until && (*server)->stats().bytes_out < to_send) {
      const size_t n = driver.poll(buf);
      got.insert(got.end(), buf.begin(), buf.begin() + static_cast<long>(n));
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    // Everything is sent; the driver may still be decoding it (a loaded machine): take what it
    // gives until it has given nothing for 300 ms (bounded on its own: sending may have taken
    // most of the first deadline).
    const auto drained_by = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    for (auto last = std::chrono::steady_clock::now();
         std::chrono::steady_clock::now() - last < std::chrono::milliseconds(300) &&
         std::chrono::steady_clock::now() < drained_by;) {
      const size_t n = driver.poll(buf);
      if (n > 0) last = std::chrono::steady_clock::now();
      got.insert(got.end(), buf.begin(), buf.begin() + static_cast<long>(n));
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    EXPECT_EQ(driver.dropped_samples(), 0u);
    driver.stop();
    (*server)->stop();
    return got;
  };
  const auto again = replay(raw);
  ASSERT_GE(again.size(), recorded.size());
  for (size_t i = 0; i < recorded.size(); ++i) {
    ASSERT_EQ(again[i].sensor, recorded[i].sensor) << i;
    ASSERT_EQ(again[i].position_m, recorded[i].position_m) << i;
    ASSERT_EQ(again[i].orientation, recorded[i].orientation) << i;
  }
  // One byte of a position word in the stream, changed (the low data byte of X, bit 0 clear).
  size_t last = raw.size() - 1;
  while (last > 0 && !(raw[last].direction == RawDirection::from_device && raw[last].bytes.size() >= 4)) --last;
  ASSERT_GT(last, 0u);
  std::vector<RawChunk> tampered = raw;
  tampered[last].bytes[1] ^= 0x10;  // a data byte (phasing bit 7 untouched)
  const auto changed = replay(tampered);
  size_t differing = 0;
  for (size_t i = 0; i < std::min(changed.size(), again.size()); ++i)
    differing +=
        (changed[i].position_m != again[i].position_m || changed[i].orientation != again[i].orientation) ? 1 : 0;
  EXPECT_GE(differing, 1u);
}

}  // namespace
}  // namespace mimic::sim::raw_session_test
