// The lean pose stream (POSE_DELTA, docs/protocol.md): pose frames as key frames and small
// predicted deltas, for subscribers that ask for capability bit kCapLeanPose. Pure code, no I/O.
//
// Values are the POSE frame's own quantised integers (root position in 10 µm, quaternion
// components in 1/32767, angles in π/32767 rad) divided by 2^shift (the stream's precision;
// kDefaultPoseShift unless configured). A key frame carries the values of its frame and of the
// frame before it; a delta frame carries the residual of every value against the linear
// prediction 2·v[s−1] − v[s−2] from the two frames its receiver last applied. The reference rule:
// a delta with sequence s applies only to a receiver whose state is at sequence s−1 (and was built
// from the same stream); anything else is refused (Reject::unexpected) without touching the state,
// and the receiver waits for, or asks for, a key frame. Everything is integer arithmetic, so the
// server's encoder state and every receiver's state agree bit for bit.
//
// Error bound (decode against the original float pose): per value (2^shift + 1)/2 steps of the
// POSE frame's quantisation (with shift 3: 4.5 steps — angles ±4.3e-4 rad, root ±45 µm,
// quaternion components ±1.4e-4 before renormalisation).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "mimic/rig/skeleton.h"
#include "mimic/net/frame_codec.h"

namespace mimic::net {

inline constexpr uint8_t kDefaultPoseShift = 3;
inline constexpr uint8_t kMaxPoseShift = 8;
// Key frames of larger skeletons might not fit one datagram: their subscribers get POSE frames.
inline constexpr size_t kMaxLeanPoseDofs = 200;
// Header flags of a POSE_DELTA packet.
inline constexpr uint8_t kLeanKey = 1u << 0;    // a key frame (else a delta)
inline constexpr uint8_t kLeanStale = 1u << 1;  // PoseHeader::flags kPoseStale

// What a receiver holds of one avatar's lean stream (and what the server's encoder mirrors).
// Fixed size: applying a frame never allocates.
struct LeanPoseState {
  static constexpr size_t kMaxValues = 7 + kMaxLeanPoseDofs;  // root xyz, quaternion xyzw, DOFs
  bool valid = false;
  uint8_t shift = kDefaultPoseShift;
  uint16_t avatar = 0;
  uint16_t dof_count = 0;
  uint32_t sequence = 0;
  uint64_t time_us = 0;
  std::array<int64_t, kMaxValues> current{};   // values of frame `sequence`
  std::array<int64_t, kMaxValues> previous{};  // values of frame `sequence − 1` (as predicted from)
  size_t value_count() const { return 7u + dof_count; }
};

// Server side, one per avatar: fed every accepted POSE packet once, it encodes the delta frame
// once (shared by every subscriber stream whose receiver is at the previous frame) and the key
// frame at most once, on demand (for joiners, subscribers that skipped frames, periodic keys).
class LeanPoseEncoder {
 public:
  // `key_interval`: every frame whose sequence is a multiple of it goes as a key to everyone
  // (recovery for receivers that lost a datagram and cannot ask); 0: never.
  LeanPoseEncoder() : LeanPoseEncoder(kDefaultPoseShift, 90) {}
  explicit LeanPoseEncoder(uint8_t shift, uint32_t key_interval = 90);

  // A validated POSE packet (decode_pose accepted it). False when its skeleton is too large for
  // the lean stream (subscribers then get the POSE packet itself).
  bool update(std::span<const uint8_t> pose_packet) noexcept;
  void reset() noexcept {
    state_.valid = false;
    delta_size_ = key_size_ = 0;
  }

  bool valid() const { return state_.valid; }
  uint32_t sequence() const { return state_.sequence; }
  // The delta from the previous frame; empty when this frame must go as a key frame.
  std::span<const uint8_t> delta() const { return {delta_.data(), delta_size_}; }
  // The key frame of the current frame (encoded on first call).
  std::span<const uint8_t> key() noexcept;
  // A receiver whose state is at `receiver_sequence` (0 or anything but the previous frame if
  // unknown) gets this packet for the current frame.
  std::span<const uint8_t> packet_for(uint32_t receiver_sequence) noexcept {
    return receiver_sequence + 1 == state_.sequence && delta_size_ ? delta() : key();
  }
  const LeanPoseState& state() const { return state_; }

 private:
  uint8_t shift_;
  uint32_t key_interval_;
  LeanPoseState state_;
  std::array<int64_t, LeanPoseState::kMaxValues> scratch_{};
  uint16_t flags_ = 0;
  std::array<uint8_t, kMaxDatagramBytes> delta_{}, key_{};
  size_t delta_size_ = 0, key_size_ = 0;
};

// Encodes one key frame of `state` into `out` (packet size, or 0 if it does not fit).
size_t encode_lean_key(const LeanPoseState& state, uint16_t pose_flags, std::span<uint8_t> out) noexcept;

// Applies a POSE_DELTA packet to `state` and writes the pose it gives (`out.dof_rad` resized to
// the DOF count; no allocation once it fits). Refuses, leaving `state` as it was:
// Reject::unexpected for a delta that does not follow `state` (lost or skipped frame: wait for a
// key), Reject::out_of_order for a key not newer than `state`, malformed/truncated otherwise.
Reject decode_lean_pose(std::span<const uint8_t> packet, LeanPoseState& state, PoseHeader& header,
                        rig::Pose& out) noexcept;

// The pose a state holds (after decode_lean_pose accepted a packet).
void lean_state_pose(const LeanPoseState& state, rig::Pose& out) noexcept;

// Reads sequence and avatar of a POSE_DELTA packet without decoding it.
uint32_t lean_pose_sequence(std::span<const uint8_t> packet) noexcept;
bool lean_pose_is_key(std::span<const uint8_t> packet) noexcept;

}  // namespace mimic::net
