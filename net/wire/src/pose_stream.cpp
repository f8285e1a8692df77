#include "mimic/net/pose_stream.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace mimic::net {

namespace {

constexpr size_t kGroup = 4;        // values sharing one width code
constexpr unsigned kWideBits = 20;  // width code 15: any residual of i16-range values fits

uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ uint64_t(v >> 63); }
int64_t unzigzag(uint64_t u) { return int64_t(u >> 1) ^ -int64_t(u & 1); }
// Residuals from the wire are arbitrary 64-bit values: sums wrap (defined) instead of overflowing,
// and values_in_range() refuses whatever lands outside the quantised ranges.
int64_t wrapping_add(int64_t a, int64_t b) { return int64_t(uint64_t(a) + uint64_t(b)); }

unsigned width_of(uint64_t u) { return u == 0 ? 0u : unsigned(64 - std::countl_zero(u)); }

struct ByteOut {
  std::span<uint8_t> out;
  size_t pos = 0;
  bool ok = true;
  void u8(uint8_t v) {
    if (pos >= out.size()) {
      ok = false;
      return;
    }
    out[pos++] = v;
  }
  void le(uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) u8(uint8_t(v >> (8 * i)));
  }
  void varint(uint64_t v) {
    while (v >= 0x80) {
      u8(uint8_t(v | 0x80));
      v >>= 7;
    }
    u8(uint8_t(v));
  }
};

// LSB-first bit packing after the byte-aligned fields.
struct BitOut {
  ByteOut& b;
  uint64_t acc = 0;
  unsigned n = 0;
  void put(uint64_t v, unsigned bits) {
    for (unsigned done = 0; done < bits;) {
      const unsigned take = std::min(bits - done, 32u);
      acc |= ((v >> done) & ((uint64_t(1) << take) - 1)) << n;
      n += take;
      done += take;
      while (n >= 8) {
        b.u8(uint8_t(acc));
        acc >>= 8;
        n -= 8;
      }
    }
  }
  void finish() {
    if (n) b.u8(uint8_t(acc));
    acc = 0;
    n = 0;
  }
};

// Groups of kGroup values: a 4-bit width code (0–14 bits, 15 = kWideBits) then each value's
// zigzag in that many bits.
void put_groups(BitOut& w, const int64_t* v, size_t count) {
  for (size_t i = 0; i < count; i += kGroup) {
    const size_t m = std::min(kGroup, count - i);
    unsigned width = 0;
    for (size_t j = 0; j < m; ++j) width = std::max(width, width_of(zigzag(v[i + j])));
    const unsigned code = width <= 14 ? width : 15;
    const unsigned bits = code == 15 ? kWideBits : code;
    w.put(code, 4);
    for (size_t j = 0; j < m; ++j) w.put(zigzag(v[i + j]), bits);
  }
}

struct ByteIn {
  std::span<const uint8_t> in;
  size_t pos = 0;
  bool ok = true;
  uint8_t u8() {
    if (pos >= in.size()) {
      ok = false;
      return 0;
    }
    return in[pos++];
  }
  uint64_t le(int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= uint64_t(u8()) << (8 * i);
    return v;
  }
  uint64_t varint() {
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      const uint8_t b = u8();
      v |= uint64_t(b & 0x7F) << shift;
      if (!(b & 0x80)) return v;
    }
    ok = false;  // longer than 10 bytes
    return 0;
  }
};

struct BitIn {
  ByteIn& b;
  uint64_t acc = 0;
  unsigned n = 0;
  uint64_t get(unsigned bits) {
    while (n < bits) {
      if (b.pos >= b.in.size()) {
        b.ok = false;
        return 0;
      }
      acc |= uint64_t(b.in[b.pos++]) << n;
      n += 8;
    }
    const uint64_t v = bits == 64 ? acc : acc & ((uint64_t(1) << bits) - 1);
    acc = bits >= 64 ? 0 : acc >> bits;
    n -= bits;
    return v;
  }
};

bool get_groups(BitIn& r, int64_t* v, size_t count) {
  for (size_t i = 0; i < count; i += kGroup) {
    const size_t m = std::min(kGroup, count - i);
    const unsigned code = unsigned(r.get(4));
    const unsigned bits = code == 15 ? kWideBits : code;
    for (size_t j = 0; j < m; ++j) v[i + j] = unzigzag(r.get(bits));
    if (!r.b.ok) return false;
  }
  return true;
}

int64_t shifted(int64_t q, uint8_t shift) { return shift == 0 ? q : (q + (int64_t(1) << (shift - 1))) >> shift; }

int16_t read_i16(const uint8_t* p) { return int16_t(uint16_t(p[0] | (p[1] << 8))); }
int32_t read_i32(const uint8_t* p) {
  return int32_t(uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24));
}

// Decoded values must be ones an encoder could have produced from a POSE frame.
bool values_in_range(const LeanPoseState& s) {
  const int64_t root_max = (int64_t(INT32_MAX) >> s.shift) + 1;
  const int64_t small_max = (int64_t(32768) >> s.shift) + 1;
  for (size_t i = 0; i < s.value_count(); ++i) {
    const int64_t lim = i < 3 ? root_max : small_max;
    if (s.current[i] > lim || s.current[i] < -lim || s.previous[i] > lim || s.previous[i] < -lim) return false;
  }
  return true;
}

void begin_packet(ByteOut& w, uint8_t flags) {
  w.u8(kMagic);
  w.u8(kProtocolVersion);
  w.u8(uint8_t(MsgType::pose_delta));
  w.u8(flags);
  w.le(0, 4);  // payload length, set by end_packet
}

size_t end_packet(ByteOut& w) {
  if (!w.ok || w.pos > kMaxDatagramBytes) return 0;
  const uint32_t payload = uint32_t(w.pos - kHeaderBytes);
  for (int i = 0; i < 4; ++i) w.out[4 + size_t(i)] = uint8_t(payload >> (8 * i));
  return w.pos;
}

}  // namespace

size_t encode_lean_key(const LeanPoseState& s, uint16_t pose_flags, std::span<uint8_t> out) noexcept {
  if (!s.valid || s.dof_count > kMaxLeanPoseDofs) return 0;
  ByteOut w{out};
  begin_packet(w, uint8_t(kLeanKey | ((pose_flags & kPoseStale) ? kLeanStale : 0)));
  w.le(s.avatar, 2);
  w.le(s.sequence, 4);
  w.le(s.time_us, 8);
  w.u8(s.shift);
  w.le(s.dof_count, 2);
  const size_t n = s.value_count();
  std::array<int64_t, LeanPoseState::kMaxValues> back;
  for (size_t i = 0; i < n; ++i) back[i] = s.previous[i] - s.current[i];
  for (int i = 0; i < 3; ++i) w.varint(zigzag(s.current[size_t(i)]));
  for (int i = 0; i < 3; ++i) w.varint(zigzag(back[size_t(i)]));
  BitOut bits{w};
  put_groups(bits, s.current.data() + 3, n - 3);
  put_groups(bits, back.data() + 3, n - 3);
  bits.finish();
  return end_packet(w);
}

LeanPoseEncoder::LeanPoseEncoder(uint8_t shift, uint32_t key_interval)
    : shift_(std::min(shift, kMaxPoseShift)), key_interval_(key_interval) {}

bool LeanPoseEncoder::update(std::span<const uint8_t> packet) noexcept {
  delta_size_ = key_size_ = 0;
  if (packet.size() < kPoseFixedBytes) return false;
  const uint8_t* p = packet.data() + kHeaderBytes;
  const uint16_t avatar = uint16_t(p[0] | (p[1] << 8));
  flags_ = uint16_t(p[2] | (p[3] << 8));
  const uint32_t seq = pose_sequence(packet);
  uint64_t time_us = 0;
  for (int i = 0; i < 8; ++i) time_us |= uint64_t(p[8 + i]) << (8 * i);
  const uint16_t n = uint16_t(p[36] | (p[37] << 8));
  if (n > kMaxLeanPoseDofs || packet.size() != kPoseFixedBytes + 2u * n) {
    state_.valid = false;
    return false;
  }
  for (int i = 0; i < 3; ++i) scratch_[size_t(i)] = shifted(read_i32(p + 16 + 4 * i), shift_);
  for (int i = 0; i < 4; ++i) scratch_[size_t(3 + i)] = shifted(read_i16(p + 28 + 2 * i), shift_);
  for (uint16_t i = 0; i < n; ++i) scratch_[7u + i] = shifted(read_i16(p + 38 + 2 * i), shift_);
  const size_t count = 7u + n;

  // A delta needs the receiver's two previous frames: only for the frame right after the last
  // one, of the same skeleton, and not on a periodic key.
  const bool follows = state_.valid && seq == state_.sequence + 1 && n == state_.dof_count && avatar == state_.avatar;
  const bool periodic_key = key_interval_ != 0 && seq % key_interval_ == 0;
  if (follows && !periodic_key) {
    std::array<int64_t, LeanPoseState::kMaxValues> residual;
    for (size_t i = 0; i < count; ++i) residual[i] = scratch_[i] - (2 * state_.current[i] - state_.previous[i]);
    ByteOut w{delta_};
    begin_packet(w, uint8_t((flags_ & kPoseStale) ? kLeanStale : 0));
    w.le(avatar, 2);
    w.le(seq, 4);
    w.varint(zigzag(int64_t(time_us - state_.time_us)));
    for (int i = 0; i < 3; ++i) w.varint(zigzag(residual[size_t(i)]));
    BitOut bits{w};
    put_groups(bits, residual.data() + 3, count - 3);
    bits.finish();
    delta_size_ = end_packet(w);
  }
  // Advance exactly as a receiver applying this frame would.
  if (follows) {
    state_.previous = state_.current;
  } else {
    std::copy_n(scratch_.begin(), count, state_.previous.begin());
  }
  std::copy_n(scratch_.begin(), count, state_.current.begin());
  state_.valid = true;
  state_.shift = shift_;
  state_.avatar = avatar;
  state_.dof_count = n;
  state_.sequence = seq;
  state_.time_us = time_us;
  return true;
}

std::span<const uint8_t> LeanPoseEncoder::key() noexcept {
  if (key_size_ == 0 && state_.valid) key_size_ = encode_lean_key(state_, flags_, key_);
  return {key_.data(), key_size_};
}

void lean_state_pose(const LeanPoseState& s, rig::Pose& out) noexcept {
  const double unit = double(int64_t(1) << s.shift);
  for (int i = 0; i < 3; ++i)
    out.root_position_m[i] = float(double(s.current[size_t(i)]) * unit * double(kRootPositionStep_m));
  glm::quat q;
  q.x = float(double(s.current[3]) * unit * double(kQuatStep));
  q.y = float(double(s.current[4]) * unit * double(kQuatStep));
  q.z = float(double(s.current[5]) * unit * double(kQuatStep));
  q.w = float(double(s.current[6]) * unit * double(kQuatStep));
  const float len = glm::length(q);
  out.root_orientation = len > 0 ? q / len : glm::quat(1, 0, 0, 0);
  const size_t n = std::min<size_t>(s.dof_count, out.dof_rad.size());
  for (size_t i = 0; i < n; ++i) out.dof_rad[i] = float(double(s.current[7 + i]) * unit * double(kAngleStep_rad));
}

Reject decode_lean_pose(std::span<const uint8_t> packet, LeanPoseState& state, PoseHeader& h, rig::Pose& out) noexcept {
  Header hdr;
  if (const Reject e = decode_header(packet, hdr); e != Reject::ok) return e;
  if (hdr.type != MsgType::pose_delta) return Reject::unexpected;
  if (packet.size() < kHeaderBytes + hdr.payload_bytes) return Reject::truncated;
  if (packet.size() > kHeaderBytes + hdr.payload_bytes) return Reject::malformed;
  if (hdr.flags & ~uint8_t(kLeanKey | kLeanStale)) return Reject::malformed;
  ByteIn r{packet, kHeaderBytes};
  const uint16_t avatar = uint16_t(r.le(2));
  const uint32_t seq = uint32_t(r.le(4));
  LeanPoseState next;  // built aside: a refused packet leaves `state` untouched
  if (hdr.flags & kLeanKey) {
    next.time_us = r.le(8);
    next.shift = r.u8();
    next.dof_count = uint16_t(r.le(2));
    if (!r.ok) return Reject::truncated;
    if (next.shift > kMaxPoseShift || next.dof_count > kMaxLeanPoseDofs) return Reject::malformed;
    if (state.valid && state.avatar == avatar && static_cast<int32_t>(seq - state.sequence) <= 0)
      return Reject::out_of_order;
    const size_t n = next.value_count();
    for (int i = 0; i < 3; ++i) next.current[size_t(i)] = unzigzag(r.varint());
    for (int i = 0; i < 3; ++i) next.previous[size_t(i)] = wrapping_add(next.current[size_t(i)], unzigzag(r.varint()));
    if (!r.ok) return Reject::truncated;
    BitIn bits{r};
    if (!get_groups(bits, next.current.data() + 3, n - 3)) return Reject::truncated;
    if (!get_groups(bits, next.previous.data() + 3, n - 3)) return Reject::truncated;
    for (size_t i = 3; i < n; ++i) next.previous[i] = wrapping_add(next.previous[i], next.current[i]);
  } else {
    if (!state.valid || state.avatar != avatar || seq != state.sequence + 1) return Reject::unexpected;
    next.shift = state.shift;
    next.dof_count = state.dof_count;
    next.time_us = state.time_us + uint64_t(unzigzag(r.varint()));
    const size_t n = next.value_count();
    for (int i = 0; i < 3; ++i)
      next.current[size_t(i)] =
          wrapping_add(2 * state.current[size_t(i)] - state.previous[size_t(i)], unzigzag(r.varint()));
    if (!r.ok) return Reject::truncated;
    BitIn bits{r};
    if (!get_groups(bits, next.current.data() + 3, n - 3)) return Reject::truncated;
    for (size_t i = 3; i < n; ++i)
      next.current[i] = wrapping_add(next.current[i], 2 * state.current[i] - state.previous[i]);
    std::copy_n(state.current.begin(), n, next.previous.begin());
  }
  // Nothing may follow the last value.
  if (r.pos != packet.size()) return Reject::malformed;
  next.valid = true;
  next.avatar = avatar;
  next.sequence = seq;
  if (!values_in_range(next)) return Reject::malformed;
  {
    const double unit = double(int64_t(1) << next.shift) * double(kQuatStep);
    double len2 = 0;
    for (int i = 3; i < 7; ++i) len2 += std::pow(double(next.current[size_t(i)]) * unit, 2);
    if (!(len2 > 0.98 && len2 < 1.02)) return Reject::malformed;
  }
  state = next;
  h.avatar = avatar;
  h.flags = (hdr.flags & kLeanStale) ? kPoseStale : 0;
  h.sequence = seq;
  h.time_us = next.time_us;
  out.dof_rad.resize(next.dof_count);
  lean_state_pose(next, out);
  return Reject::ok;
}

uint32_t lean_pose_sequence(std::span<const uint8_t> packet) noexcept {
  if (packet.size() < kHeaderBytes + 6) return 0;
  const uint8_t* p = packet.data() + kHeaderBytes + 2;
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

bool lean_pose_is_key(std::span<const uint8_t> packet) noexcept { return packet.size() > 3 && (packet[3] & kLeanKey); }

}  // namespace mimic::net
