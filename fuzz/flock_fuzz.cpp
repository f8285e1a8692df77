// libFuzzer target for the Flock of Birds stream decoder and record conversion: any bytes, any
// layout, must never crash, read out of bounds or produce a non-finite sample.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "mimic/devices/flock_packet.h"

namespace fl = mimic::devices::flock;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  // First byte picks the layout and range; the rest is the line.
  const uint8_t sel = data[0];
  const fl::Format format = fl::kAllFormats[sel % fl::kAllFormats.size()];
  const fl::RecordLayout layout{format, (sel & 0x08) != 0, (sel & 0x10) != 0};
  const fl::PositionRange range = (sel & 0x20) ? fl::PositionRange::in144 : fl::PositionRange::in36;
  fl::StreamDecoder decoder(layout);
  if (sel & 0x40) decoder.set_valid_addresses(0x1E);
  const std::span<const uint8_t> line(data + 1, size - 1);
  // Feed in uneven chunks so records straddle reads.
  size_t pos = 0, chunk = 1 + (sel >> 7);
  uint64_t seen = 0;
  while (pos < line.size()) {
    const size_t n = std::min(chunk, line.size() - pos);
    decoder.feed(line.subspan(pos, n), [&](const fl::RawRecord& r, size_t end) {
      if (end == 0 || end > n) std::abort();
      const fl::Measurement m = fl::from_raw(r, range);
      const mimic::devices::SensorSample s = fl::to_sample(m, layout);
      if (!std::isfinite(s.position_m.x) || !std::isfinite(s.orientation.w)) std::abort();
      // Re-encoding a decoded record gives back the same words.
      uint8_t buf[fl::kMaxRecordSize];
      const size_t len = fl::encode_record(r, buf);
      auto again = fl::decode_record(std::span<const uint8_t>(buf, len), layout);
      if (!again) std::abort();
      for (int i = 0; i < fl::word_count(format); ++i)
        if (again->words[i] != r.words[i]) std::abort();
      ++seen;
    });
    pos += n;
    chunk = chunk % 17 + 1;
  }
  if (decoder.records() != seen) std::abort();
  return 0;
}
