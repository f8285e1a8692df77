// Avatar keys as numbers and text, and the message that carries a publisher's tick of pose
// frames (docs/protocol.md, "Through a broker"). Internal to net/; no NATS client needed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace mimic::net::nats_detail {

// An avatar key's value (FNV-1a 64 over "publisher/avatar") and its text, 16 lowercase hex
// digits (nats_avatar_key).
uint64_t avatar_key_value(std::string_view publisher, std::string_view avatar);
std::string avatar_key_text(uint64_t key);

// A message on mimic.S.poses.<publisher>: entries of the avatar's key value (8 bytes,
// little-endian) followed by its POSE packet, one entry per avatar of the tick.
inline constexpr size_t kPosesKeyBytes = 8;
inline void write_poses_key(uint64_t key, uint8_t* out) noexcept {
  for (size_t b = 0; b < kPosesKeyBytes; ++b) out[b] = uint8_t(key >> (8 * b));
}
inline uint64_t read_poses_key(const uint8_t* in) noexcept {
  uint64_t key = 0;
  for (size_t b = 0; b < kPosesKeyBytes; ++b) key |= uint64_t(in[b]) << (8 * b);
  return key;
}

}  // namespace mimic::net::nats_detail
