// A checker texture as PNG bytes, for glTF files that carry one material per part.
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh_io_internal.h"
#include "mimic/avatar/png.h"

namespace mimic::avatar::detail {

std::string checker_png(int size_px, int squares, glm::u8vec3 a, glm::u8vec3 b) {
  std::vector<uint8_t> rgb;
  rgb.reserve(static_cast<size_t>(size_px) * static_cast<size_t>(size_px) * 3);
  const int cell = std::max(1, size_px / std::max(1, squares));
  for (int y = 0; y < size_px; ++y)
    for (int x = 0; x < size_px; ++x) {
      const glm::u8vec3 c = ((x / cell + y / cell) % 2) ? b : a;
      rgb.insert(rgb.end(), {c.x, c.y, c.z});
    }
  // A fixed small image: encoding cannot fail short of memory, which throws.
  return encode_png(size_px, size_px, 3, rgb).value();
}

}  // namespace mimic::avatar::detail
