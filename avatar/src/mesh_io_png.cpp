// A checker texture as PNG bytes, for glTF files that carry one material per part: truecolour,
// 8 bits, the image data in stored (uncompressed) deflate blocks, so no compression library.
#include <array>
#include <cstdint>
#include <string>

#include "mesh_io_internal.h"

namespace mimic::avatar::detail {

namespace {

uint32_t crc32(const std::string& bytes, size_t from) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = from; i < bytes.size(); ++i) c = table[(c ^ static_cast<uint8_t>(bytes[i])) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

void put_be32(std::string& out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out += static_cast<char>((v >> s) & 0xFF);
}

void chunk(std::string& png, const char* type, const std::string& data) {
  put_be32(png, static_cast<uint32_t>(data.size()));
  const size_t from = png.size();
  png += type;
  png += data;
  put_be32(png, crc32(png, from));
}

}  // namespace

std::string checker_png(int size_px, int squares, glm::u8vec3 a, glm::u8vec3 b) {
  std::string raw;  // filter byte 0, then RGB per pixel, per row
  const int cell = std::max(1, size_px / std::max(1, squares));
  for (int y = 0; y < size_px; ++y) {
    raw += '\0';
    for (int x = 0; x < size_px; ++x) {
      const glm::u8vec3 c = ((x / cell + y / cell) % 2) ? b : a;
      raw += static_cast<char>(c.x), raw += static_cast<char>(c.y), raw += static_cast<char>(c.z);
    }
  }
  std::string z = "\x78\x01";  // zlib: deflate, 32K window, no preset dictionary
  for (size_t at = 0; at < raw.size() || at == 0;) {
    const size_t n = std::min<size_t>(65535, raw.size() - at);
    const bool last = at + n >= raw.size();
    z += static_cast<char>(last ? 1 : 0);
    z += static_cast<char>(n & 0xFF), z += static_cast<char>(n >> 8);
    z += static_cast<char>(~n & 0xFF), z += static_cast<char>((~n >> 8) & 0xFF);
    z.append(raw, at, n);
    at += n;
    if (last) break;
  }
  uint32_t s1 = 1, s2 = 0;  // Adler-32 of the raw data
  for (char ch : raw) {
    s1 = (s1 + static_cast<uint8_t>(ch)) % 65521;
    s2 = (s2 + s1) % 65521;
  }
  put_be32(z, (s2 << 16) | s1);

  std::string png = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  put_be32(ihdr, static_cast<uint32_t>(size_px));
  put_be32(ihdr, static_cast<uint32_t>(size_px));
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, truecolour, deflate, filter 0, no interlace
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", "");
  return png;
}

}  // namespace mimic::avatar::detail
