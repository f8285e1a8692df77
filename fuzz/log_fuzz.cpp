// libFuzzer entry point for the Mimic log decoder: any bytes either fail with a message (no
// usable header) or decode into samples up to a reported damage point; re-encoding what was
// decoded must decode to the same samples (bit-exact). Each input is tried twice: as given,
// and with every frame's CRC recomputed, so mutations reach the header and record parsers
// behind the checksums.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "mimic/core/crc32.h"
#include "mimic/sim/log.h"

namespace {

void check(const std::uint8_t* data, std::size_t size) {
  using namespace mimic::sim;
  auto log = decode_log(std::span<const std::uint8_t>(data, size));
  if (!log) {
    if (log.error().message.empty()) std::abort();
    return;
  }
  if (!log->complete && !log->damage) std::abort();  // (a complete log may have resynchronised damage)
  if (log->damage.has_value() != !log->damages.empty()) std::abort();
  if (log->damage && log->damage->byte_offset > size) std::abort();

  std::vector<std::uint8_t> again;
  encode_log_prefix(log->header, again);
  std::size_t next_raw = 0;
  for (std::size_t i = 0; i <= log->samples.size(); ++i) {
    while (next_raw < log->raw.size() && log->raw[next_raw].samples_before == i) {
      const auto& c = log->raw[next_raw++];
      encode_raw_record(c.host_time_s, c.direction, c.bytes, again);
    }
    if (i < log->samples.size()) encode_sample_record(log->samples[i], again);
  }
  encode_end_record(log->samples.size(), again);
  auto back = decode_log(again);
  if (!back || !back->complete || back->samples.size() != log->samples.size() || back->raw.size() != log->raw.size())
    std::abort();
  for (std::size_t i = 0; i < back->samples.size(); ++i) {
    const auto& a = back->samples[i];
    const auto& b = log->samples[i];
    if (a.sensor != b.sensor || a.flags != b.flags || a.buttons != b.buttons ||
        std::memcmp(&a.position_m, &b.position_m, sizeof a.position_m) != 0 ||
        std::memcmp(&a.orientation, &b.orientation, sizeof a.orientation) != 0 ||
        std::memcmp(&a.host_time_s, &b.host_time_s, sizeof a.host_time_s) != 0)
      std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  check(data, size);
  std::vector<std::uint8_t> fixed(data, data + size);
  std::size_t pos = 12;
  while (pos + 9 <= fixed.size()) {
    std::uint32_t len;
    std::memcpy(&len, fixed.data() + pos, 4);
    if (len > fixed.size() - pos - 9) break;
    const std::uint32_t crc = mimic::crc32(std::span<const std::uint8_t>(fixed.data() + pos, 5 + len));
    std::memcpy(fixed.data() + pos + 5 + len, &crc, 4);
    pos += 9 + len;
  }
  check(fixed.data(), fixed.size());
  return 0;
}
