#include "mimic/sim/flock_placement.h"

#include <algorithm>
#include <limits>

namespace mimic::sim {

FlockPlacement place_flock_transmitter(std::span<const glm::vec3> world_positions_m, double margin_m) {
  FlockPlacement out;
  if (world_positions_m.empty()) return out;
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
  for (const glm::vec3& p : world_positions_m) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  // Across (x) and up (y) the transmitter sits in the middle, which halves the range needed;
  // along z every sample must be in front of it (the forward hemisphere), so it stands behind.
  const glm::dvec3 at(0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y), lo.z - margin_m);
  out.world_from_transmitter.translation = glm::vec3(at);
  out.needed_range_m = std::max({hi.x - at.x, hi.y - at.y, hi.z - at.z});
  return out;
}

}  // namespace mimic::sim
