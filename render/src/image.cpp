#include "mimic/render/image.h"

#include <png.h>

#include <algorithm>
#include <cstdlib>

#include "mimic/avatar/png.h"
#include "mimic/core/file.h"

namespace mimic::render {

Status write_png(const Image& image, const std::string& path) {
  auto png = avatar::encode_png(image.width, image.height, 4, image.rgba);
  if (!png) return tl::unexpected(png.error());
  return write_file_atomic(path, *png);
}

Result<Image> read_png(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str()))
    return fail(Errc::io_error, "cannot read PNG " + path + ": " + png.message);
  png.format = PNG_FORMAT_RGBA;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgba.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr)) {
    png_image_free(&png);
    return fail(Errc::parse_error, "bad PNG " + path + ": " + png.message);
  }
  return image;
}

Coverage coverage(const Image& image, const uint8_t background[3], int tolerance) {
  Coverage c;
  c.min_x = image.width;
  c.min_y = image.height;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      bool differs = false;
      for (int k = 0; k < 3; ++k) differs |= std::abs(int(p[k]) - int(background[k])) > tolerance;
      if (!differs) continue;
      ++c.count;
      c.min_x = std::min(c.min_x, x);
      c.max_x = std::max(c.max_x, x);
      c.min_y = std::min(c.min_y, y);
      c.max_y = std::max(c.max_y, y);
    }
  if (c.count == 0) c = Coverage{};
  return c;
}

}  // namespace mimic::render
