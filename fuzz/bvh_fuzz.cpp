// libFuzzer entry point for the BVH parser: any bytes must either parse into a consistent clip
// or fail with a message; forward kinematics of every parsed frame must stay finite-safe.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "mimic/rig/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mimic;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto clip = rig::parse_bvh(text, "fuzz.bvh");
  if (!clip) {
    if (clip.error().message.empty()) std::abort();
    return 0;
  }
  if (clip->values.size() != static_cast<std::size_t>(clip->frame_count) * clip->channel_count) std::abort();
  std::vector<rig::RigidTransform> world(clip->joints.size());
  for (int f = 0; f < clip->frame_count && f < 4; ++f) rig::bvh_forward_kinematics(*clip, f, world);
  return 0;
}
