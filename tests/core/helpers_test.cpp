// The shared helpers of core/: CRC-32, percentiles, HOST:PORT, finite checks, the allocation
// counter's absence here (core itself never replaces operator new).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <vector>

#include "mimic/core/clock.h"
#include "mimic/core/crc32.h"
#include "mimic/core/finite.h"
#include "mimic/core/host_port.h"
#include "mimic/core/percentile.h"
#include "mimic/core/thread_priority.h"

namespace mimic::helpers_test {
namespace {

std::span<const uint8_t> bytes_of(const char* text) {
  return {reinterpret_cast<const uint8_t*>(text), std::strlen(text)};
}

TEST(Crc32, MatchesTheStandardCheckValueAndContinues) {
  EXPECT_EQ(crc32(bytes_of("123456789")), 0xCBF43926u);
  EXPECT_EQ(crc32(bytes_of("56789"), crc32(bytes_of("1234"))), 0xCBF43926u);
  EXPECT_EQ(crc32(bytes_of("")), 0u);
}

TEST(Percentile, NearestRankOfUnorderedSamples) {
  std::vector<double> v{9, 1, 8, 2, 7, 3, 6, 4, 5, 10};
  EXPECT_EQ(percentile_in_place(v, 0.0), 1);
  EXPECT_EQ(percentile_in_place(v, 1.0), 10);
  EXPECT_EQ(percentile_in_place(v, 0.5), 6);  // rank 4.5 rounds to the 6th smallest
  EXPECT_EQ(percentile_in_place(v, 2.0), 10) << "q is clamped to [0, 1]";
  std::vector<double> none;
  EXPECT_EQ(percentile_in_place(none, 0.5), 0);
}

TEST(HostPort, NamesAddressesAndBracketedIpv6) {
  auto a = split_host_port("127.0.0.1:7777");
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_EQ(a->host, "127.0.0.1");
  EXPECT_EQ(a->port, 7777);
  auto b = split_host_port("[::1]:0");
  ASSERT_TRUE(b);
  EXPECT_EQ(b->host, "::1");
  EXPECT_EQ(b->port, 0);
  EXPECT_EQ(split_host_port("tracker.local:65535")->host, "tracker.local");
}

TEST(HostPort, RefusesWhatIsNotAnAddressWithAPort) {
  for (const char* bad : {"", "7777", ":7777", "host:", "host:65536", "host:-1", "host:12ab", "host:+5"}) {
    auto r = split_host_port(bad);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().code, Errc::invalid_argument);
    EXPECT_NE(r.error().message.find(bad), std::string::npos) << r.error().message;
  }
  EXPECT_EQ(*parse_port("39539"), 39539);
  EXPECT_NE(parse_port("x", "VMC port").error().message.find("VMC port"), std::string::npos);
}

TEST(Finite, RefusesNanAndInfinityInEveryShape) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> ok{1, 2, 3}, bad{1, nan, 3};
  EXPECT_TRUE(all_finite(std::span<const float>(ok)));
  EXPECT_FALSE(all_finite(std::span<const float>(bad)));
  EXPECT_TRUE(all_finite(glm::vec3(1, 2, 3)));
  EXPECT_FALSE(all_finite(glm::vec3(1, inf, 3)));
  EXPECT_FALSE(all_finite(glm::quat(nan, 0, 0, 0)));
  EXPECT_TRUE(all_finite(glm::dvec2(1, 2)));
}

TEST(Clock, ManualClockMovesOnlyWhenTold) {
  ManualClock c(5);
  EXPECT_EQ(c.now_s(), 5);
  c.advance(0.25);
  EXPECT_EQ(c.now_s(), 5.25);
  SteadyClock s;
  const double a = s.now_s(), b = s.now_s();
  EXPECT_LE(a, b);
}

// The wake-up latency request writes the bound as the device wants it (a binary 32-bit integer,
// negative bounds as 0) and holds it while the object lives; on the kernel's own device the
// aggregate bound reads back as 0 while held (skipped without root).
TEST(CpuWakeupLatency, WritesTheBoundAndHoldsItWhileAlive) {
  const auto path = std::filesystem::temp_directory_path() / ("mimic-qos-" + std::to_string(::getpid()));
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fclose(f);
  for (const int bound : {0, 25, -3}) {
    {
      const CpuWakeupLatency held(bound, path.c_str());
      EXPECT_TRUE(held.ok());
    }
    int32_t written = -1;
    f = std::fopen(path.c_str(), "rb");
    ASSERT_NE(f, nullptr);
    ASSERT_EQ(std::fread(&written, sizeof written, 1, f), 1u);
    std::fclose(f);
    EXPECT_EQ(written, bound < 0 ? 0 : bound);
    std::filesystem::resize_file(path, 0);
  }
  std::filesystem::remove(path);
  EXPECT_FALSE(CpuWakeupLatency(0, "/nonexistent/cpu_dma_latency").ok());

  const CpuWakeupLatency held(0);
  if (!held.ok()) GTEST_SKIP() << "/dev/cpu_dma_latency is not writable here";
  f = std::fopen("/dev/cpu_dma_latency", "rb");
  ASSERT_NE(f, nullptr);
  int32_t current = -1;
  ASSERT_EQ(std::fread(&current, sizeof current, 1, f), 1u);
  std::fclose(f);
  EXPECT_EQ(current, 0);
}

}  // namespace
}  // namespace mimic::helpers_test
