#include "mimic/avatar/png.h"

#include <png.h>

namespace mimic::avatar {

Result<std::string> encode_png(int width, int height, int channels, std::span<const uint8_t> pixels, bool keep_alpha) {
  if (width <= 0 || height <= 0 || (channels != 3 && channels != 4) ||
      pixels.size() != static_cast<size_t>(width) * static_cast<size_t>(height) * static_cast<size_t>(channels))
    return fail(Errc::invalid_argument, "encode_png: image size does not match its pixels");
  // libpng's simplified API writes RGB from RGBA by dropping alpha only through a background
  // composite; opaque output is asked for by converting rows first.
  std::vector<uint8_t> rgb;
  const uint8_t* data = pixels.data();
  int out_channels = channels;
  if (channels == 4 && !keep_alpha) {
    rgb.resize(static_cast<size_t>(width) * static_cast<size_t>(height) * 3);
    for (size_t i = 0, n = rgb.size() / 3; i < n; ++i)
      for (int k = 0; k < 3; ++k) rgb[i * 3 + static_cast<size_t>(k)] = pixels[i * 4 + static_cast<size_t>(k)];
    data = rgb.data();
    out_channels = 3;
  }
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = out_channels == 4 ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, data, 0, nullptr))
    return fail(Errc::io_error, std::string("libpng: ") + image.message);
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, data, 0, nullptr))
    return fail(Errc::io_error, std::string("libpng: ") + image.message);
  out.resize(size);
  return out;
}

}  // namespace mimic::avatar
