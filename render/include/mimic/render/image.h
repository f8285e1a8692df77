// An RGBA8 image, top row first, and PNG files (libpng). What screenshots are and what the
// tests read back.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mimic/core/result.h"

namespace mimic::render {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4, row 0 at the top

  const uint8_t* pixel(int x, int y) const { return &rgba[(static_cast<size_t>(y) * width + x) * 4]; }
};

// Writes an 8-bit RGB PNG (alpha dropped: screenshots are opaque), atomically (temp + rename).
Status write_png(const Image& image, const std::string& path);
// Reads any 8-bit or 16-bit PNG into RGBA8.
Result<Image> read_png(const std::string& path);

// Pixels that differ from `background` by more than `tolerance` in any channel.
struct Coverage {
  int count = 0;
  int min_x = 0, min_y = 0, max_x = -1, max_y = -1;  // bounding box (inclusive); empty when count == 0
};
Coverage coverage(const Image& image, const uint8_t background[3], int tolerance = 8);

}  // namespace mimic::render
