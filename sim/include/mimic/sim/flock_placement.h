// Where to put a virtual Flock of Birds' transmitter so that every sensor of a motion stays
// within range and in the forward hemisphere, and which range that needs.
//
// A Flock reports positions in the transmitter's frame, each axis as a 14-bit word of a full
// scale of 36 in (standard transmitter) or 144 in (extended range transmitter): beyond it on any
// axis the word pins at its limit. It cannot tell a position from its mirror image through the
// transmitter, so it reports the one in the selected hemisphere (forward by default). The
// transmitter here keeps Mimic's axes (it faces +Z, the body's forward), so "forward" is
// reference z >= 0.
//
// Input: sensor positions in Mimic's world (metres), sampled over the whole motion. Output: the
// transmitter centred on the sensors' extent across and up, `margin_m` behind the rearmost
// sample, and the largest per-axis distance a sample then has from it.
#pragma once

#include <span>

#include <glm/glm.hpp>

#include "mimic/rig/transform.h"

namespace mimic::sim {

inline constexpr double kFlockStandardRange_m = 36 * 0.0254;   // 0.9144 m
inline constexpr double kFlockExtendedRange_m = 144 * 0.0254;  // 3.6576 m

struct FlockPlacement {
  rig::RigidTransform world_from_transmitter;  // rotation identity: facing +Z
  double needed_range_m = 0;                   // max over samples and axes of |position in the transmitter frame|
  bool fits_standard() const { return needed_range_m <= kFlockStandardRange_m; }
  bool fits_extended() const { return needed_range_m <= kFlockExtendedRange_m; }
};

// Empty input: the transmitter at the origin and a needed range of 0.
FlockPlacement place_flock_transmitter(std::span<const glm::vec3> world_positions_m, double margin_m = 0.1);

}  // namespace mimic::sim
