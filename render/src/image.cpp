#include "mimic/render/image.h"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>

namespace mimic::render {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

}  // namespace

Status write_png(const Image& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != static_cast<size_t>(image.width) * image.height * 4)
    return fail(Errc::invalid_argument, "write_png: image size does not match its pixels");
  const std::string tmp = path + ".tmp";
  File f(std::fopen(tmp.c_str(), "wb"));
  if (!f) return fail(Errc::io_error, path + ": cannot create: " + std::strerror(errno));
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return fail(Errc::io_error, "libpng: out of memory");
  }
  std::vector<uint8_t> row(static_cast<size_t>(image.width) * 3);
  // libpng reports errors by longjmp: nothing with a destructor is created past this point.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    f.reset();
    std::remove(tmp.c_str());
    return fail(Errc::io_error, "libpng failed writing " + path);
  }
  png_init_io(png, f.get());
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 9);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    const uint8_t* src = image.pixel(0, y);
    for (int x = 0; x < image.width; ++x) {
      row[x * 3 + 0] = src[x * 4 + 0];
      row[x * 3 + 1] = src[x * 4 + 1];
      row[x * 3 + 2] = src[x * 4 + 2];
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(f.get()) != 0) return fail(Errc::io_error, "cannot write " + tmp);
  f.reset();
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return fail(Errc::io_error, "cannot rename " + tmp + " to " + path + ": " + ec.message());
  return {};
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
