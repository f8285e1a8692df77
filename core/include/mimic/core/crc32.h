// CRC-32 (ISO-HDLC, the polynomial of zlib, PNG and Ethernet), computed by zlib.
#pragma once

#include <cstdint>
#include <span>

namespace mimic {

// Continues `crc` (0 to start) over `bytes`: crc32(b, crc32(a)) == crc32(a followed by b).
uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc = 0) noexcept;

}  // namespace mimic
