#include "mimic/core/crc32.h"

#include <algorithm>

#include <zlib.h>

namespace mimic {

uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc) noexcept {
  uLong c = crc;
  // zlib takes a uInt length: feed spans larger than 4 GiB in pieces.
  for (size_t at = 0; at < bytes.size();) {
    const size_t n = std::min<size_t>(bytes.size() - at, 1u << 30);
    c = ::crc32(c, bytes.data() + at, static_cast<uInt>(n));
    at += n;
  }
  return static_cast<uint32_t>(c);
}

}  // namespace mimic
