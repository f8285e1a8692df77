// PNG encoding (libpng): the product's one PNG writer, for the textures glTF files carry and the
// viewer's screenshots.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "mimic/core/result.h"

namespace mimic::avatar {

// `pixels` holds height rows of width × channels bytes (channels 3: RGB, 4: RGBA), top row first.
// Written as 8-bit RGB (alpha dropped when `keep_alpha` is false: screenshots are opaque).
Result<std::string> encode_png(int width, int height, int channels, std::span<const uint8_t> pixels,
                               bool keep_alpha = false);

}  // namespace mimic::avatar
