// Biovision Hierarchy (BVH) motion clips: parsing, forward kinematics and export.
//
// A clip keeps the file's numbers as written: offsets and position channels in file units,
// rotation channels in degrees (never wrapped: |448|° is a valid value). `metres_per_unit`
// converts lengths to metres; forward kinematics reports metres.
//
// Reading convention (the standard one): a joint's local transform is
//   T(offset [+ position channels]) · R(ch1) · R(ch2) · R(ch3) …
// with the rotation channels applied in the order they are listed (column vectors).
//
// Errors: malformed text gives Errc::parse_error with "<source>:<line>: <cause>", e.g.
// "clip.bvh:37: expected 3 numbers after OFFSET, got 'abc'". Nothing is ever silently read
// as zero; non-finite numbers are rejected.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/rig/transform.h"
#include "mimic/core/result.h"

namespace mimic::rig {

// CMU's ASF unit: (1 / 0.45) inch = (1 / 0.45) · 2.54 / 100 m.
inline constexpr double kCmuMetresPerUnit = (1.0 / 0.45) * 2.54 / 100.0;

enum class BvhChannel : std::uint8_t { x_position, y_position, z_position, x_rotation, y_rotation, z_rotation };

const char* bvh_channel_name(BvhChannel c);  // "Xposition" … "Zrotation"

struct BvhJoint {
  std::string name;
  int parent = -1;                    // index into BvhClip::joints, -1 for the root
  glm::dvec3 offset{0.0};             // from the parent, file units
  std::vector<BvhChannel> channels;   // in file order
  int first_channel = 0;              // column of channels[0] in a frame row
  std::vector<glm::dvec3> end_sites;  // End Site offsets, file units (usually 0 or 1)
};

struct BvhClip {
  std::string source_name;
  std::vector<BvhJoint> joints;  // file order: parents always before children
  int channel_count = 0;
  int frame_count = 0;
  double frame_time_s = 0;
  double metres_per_unit = kCmuMetresPerUnit;
  std::vector<double> values;  // frame_count rows of channel_count values, as written

  std::span<const double> frame(int f) const {
    return std::span<const double>(values).subspan(static_cast<size_t>(f) * channel_count, channel_count);
  }
  int find_joint(std::string_view name) const;  // -1 if absent
};

struct BvhParseOptions {
  double metres_per_unit = kCmuMetresPerUnit;
};

// Parses BVH text. `source_name` (usually the file name) prefixes every error message.
Result<BvhClip> parse_bvh(std::string_view text, std::string_view source_name, const BvhParseOptions& options = {});
Result<BvhClip> load_bvh(const std::string& path, const BvhParseOptions& options = {});

// world_from_joint for every clip joint at frame f, translations in metres.
// world_from_joint.size() == clip.joints.size(); never allocates.
void bvh_forward_kinematics(const BvhClip& clip, int frame, std::span<RigidTransform> world_from_joint);

// Local rotation of joint j from its rotation channels at frame f (position channels ignored).
glm::dquat bvh_local_rotation(const BvhClip& clip, int joint, int frame);

// Mimic poses as BVH text: Mimic's hierarchy, the root with Xposition Yposition Zposition
// Zrotation Yrotation Xrotation (root orientation) followed by one rotation channel per root
// DOF, every other joint one rotation channel per DOF in DOF order (axis ±X/±Y/±Z becomes
// X/Y/Zrotation, the sign folded into the value). Leaf joints get an End Site at their tip.
// Lengths are written in units of `metres_per_unit` (the same default as parse_bvh, so a
// default write reads back at the right size). Fails if a DOF axis is not a coordinate axis
// or a pose does not match the skeleton.
Result<std::string> write_bvh(const Skeleton& skeleton, std::span<const Pose> poses, double frame_time_s,
                              double metres_per_unit = kCmuMetresPerUnit);

}  // namespace mimic::rig
