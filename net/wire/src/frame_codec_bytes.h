// The frame codec's byte-level helpers, shared by its encoders (frame_codec.cpp) and decoders
// (frame_decode.cpp): a little-endian writer and reader over caller-owned bytes that turn
// `ok` false instead of running past the end, and the header framing every packet shares.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>

#include "mimic/net/frame_codec.h"

namespace mimic::net::codec_detail {

// Little-endian writer over a caller-owned buffer; `ok` turns false on overflow.
struct Writer {
  std::span<uint8_t> out;
  size_t pos = 0;
  bool ok = true;

  void bytes(const void* p, size_t n) {
    if (!ok || out.size() - pos < n) {
      ok = false;
      return;
    }
    if (n) std::memcpy(out.data() + pos, p, n);
    pos += n;
  }
  void u8(uint8_t v) { bytes(&v, 1); }
  void u16(uint16_t v) {
    const uint8_t b[2] = {uint8_t(v), uint8_t(v >> 8)};
    bytes(b, 2);
  }
  void u32(uint32_t v) {
    const uint8_t b[4] = {uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
    bytes(b, 4);
  }
  void u64(uint64_t v) {
    u32(uint32_t(v));
    u32(uint32_t(v >> 32));
  }
  void i16(int16_t v) { u16(static_cast<uint16_t>(v)); }
  void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void str8(std::string_view s) {
    u8(static_cast<uint8_t>(s.size()));
    bytes(s.data(), s.size());
  }
};

struct Reader {
  std::span<const uint8_t> in;
  size_t pos = 0;
  bool ok = true;

  bool need(size_t n) {
    if (!ok || in.size() - pos < n) ok = false;
    return ok;
  }
  uint8_t u8() {
    if (!need(1)) return 0;
    return in[pos++];
  }
  uint16_t u16() {
    if (!need(2)) return 0;
    const uint16_t v = uint16_t(in[pos] | (in[pos + 1] << 8));
    pos += 2;
    return v;
  }
  uint32_t u32() {
    if (!need(4)) return 0;
    const uint32_t v = uint32_t(in[pos]) | (uint32_t(in[pos + 1]) << 8) | (uint32_t(in[pos + 2]) << 16) |
                       (uint32_t(in[pos + 3]) << 24);
    pos += 4;
    return v;
  }
  uint64_t u64() {
    const uint64_t lo = u32();
    const uint64_t hi = u32();
    return lo | (hi << 32);
  }
  int16_t i16() { return static_cast<int16_t>(u16()); }
  int32_t i32() { return static_cast<int32_t>(u32()); }
  float f32() { return std::bit_cast<float>(u32()); }
  bool str(size_t n, std::string& out) {
    if (!need(n)) return false;
    out.assign(reinterpret_cast<const char*>(in.data() + pos), n);
    pos += n;
    return true;
  }
  size_t left() const { return in.size() - pos; }
  void token(SessionToken& t) {
    if (!need(kTokenBytes)) return;
    std::memcpy(t.bytes.data(), in.data() + pos, kTokenBytes);
    pos += kTokenBytes;
  }
};

// Writes the header with a placeholder length; finish() patches it.
inline Writer begin(std::span<uint8_t> out, MsgType type) {
  Writer w{out};
  w.u8(kMagic);
  w.u8(kProtocolVersion);
  w.u8(static_cast<uint8_t>(type));
  w.u8(0);
  w.u32(0);
  return w;
}

inline size_t finish(Writer& w) {
  if (!w.ok) return 0;
  const uint32_t payload = static_cast<uint32_t>(w.pos - kHeaderBytes);
  if (w.pos > max_packet_bytes(w.out[2])) return 0;
  w.out[4] = uint8_t(payload);
  w.out[5] = uint8_t(payload >> 8);
  w.out[6] = uint8_t(payload >> 16);
  w.out[7] = uint8_t(payload >> 24);
  return w.pos;
}

// Validates the header of a whole packet of the expected type and positions a reader on the
// payload.
inline Reject open(std::span<const uint8_t> packet, MsgType type, Reader& r) noexcept {
  Header h;
  if (const Reject e = decode_header(packet, h); e != Reject::ok) return e;
  if (h.type != type) return Reject::unexpected;
  if (packet.size() != kHeaderBytes + h.payload_bytes)
    return packet.size() < kHeaderBytes + h.payload_bytes ? Reject::truncated : Reject::malformed;
  r = Reader{packet.subspan(kHeaderBytes)};
  return Reject::ok;
}

// Truncated when a field ran past the end, malformed when bytes are left over.
inline Reject close(const Reader& r) noexcept {
  if (!r.ok) return Reject::truncated;
  return r.left() == 0 ? Reject::ok : Reject::malformed;
}

inline int16_t quantise(float v, float step) {
  const float q = std::round(v / step);
  return static_cast<int16_t>(std::clamp(q, -32767.0f, 32767.0f));
}

inline float wrap_angle(float a) {
  constexpr float kPi = 3.14159265358979f, kTwoPi = 2 * kPi;
  if (!std::isfinite(a)) return 0.0f;
  if (a >= -kPi && a <= kPi) return a;
  a = std::fmod(a + kPi, kTwoPi);
  if (a < 0) a += kTwoPi;
  return a - kPi;
}

}  // namespace mimic::net::codec_detail
