#include "mimic/net/vrpn_wire.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace mimic::net::vrpn {

namespace {
constexpr char kMagic[] = "vrpn: ver. 07.35";  // 16 characters
constexpr size_t kMagicBytes = 16;
constexpr size_t kMajorBytes = 14;  // "vrpn: ver. 07." : what must match
}  // namespace

uint32_t load_be32(const uint8_t* p) {
  return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
}

void store_be32(uint8_t* p, uint32_t v) {
  p[0] = uint8_t(v >> 24);
  p[1] = uint8_t(v >> 16);
  p[2] = uint8_t(v >> 8);
  p[3] = uint8_t(v);
}

void store_be_f64(uint8_t* p, double v) {
  const uint64_t b = std::bit_cast<uint64_t>(v);
  store_be32(p, uint32_t(b >> 32));
  store_be32(p + 4, uint32_t(b));
}

double load_be_f64(const uint8_t* p) { return std::bit_cast<double>(uint64_t(load_be32(p)) << 32 | load_be32(p + 4)); }

Timestamp timestamp_from_seconds(double unix_s) {
  if (!(unix_s > 0)) return {};
  const double whole = std::floor(unix_s);
  Timestamp t;
  t.seconds = static_cast<uint32_t>(whole);
  t.microseconds = static_cast<uint32_t>(std::min(999999.0, std::round((unix_s - whole) * 1e6)));
  return t;
}

void write_cookie(std::span<uint8_t, kCookieBytes> out) {
  std::memset(out.data(), 0, out.size());
  std::memcpy(out.data(), kMagic, kMagicBytes);
  out[16] = ' ';
  out[17] = ' ';
  out[18] = '0';  // no remote logging asked of the peer
}

bool cookie_ok(std::span<const uint8_t, kCookieBytes> cookie) {
  if (std::memcmp(cookie.data(), kMagic, kMajorBytes) != 0) return false;
  return cookie[18] >= '0' && cookie[18] <= '3';
}

size_t write_message(std::span<uint8_t> out, Timestamp time, int32_t sender, int32_t type, uint32_t sequence,
                     std::span<const uint8_t> payload) {
  const size_t total = message_bytes(payload.size());
  if (out.size() < total) return 0;
  uint8_t* p = out.data();
  store_be32(p, static_cast<uint32_t>(kHeaderBytes + payload.size()));
  store_be32(p + 4, time.seconds);
  store_be32(p + 8, time.microseconds);
  store_be32(p + 12, static_cast<uint32_t>(sender));
  store_be32(p + 16, static_cast<uint32_t>(type));
  store_be32(p + 20, sequence);
  if (!payload.empty()) std::memcpy(p + kHeaderBytes, payload.data(), payload.size());
  std::memset(p + kHeaderBytes + payload.size(), 0, total - kHeaderBytes - payload.size());
  return total;
}

size_t write_description(std::span<uint8_t> out, std::string_view name) {
  const size_t n = name.size() + 1;
  if (n > kMaxNameBytes || out.size() < 4 + n) return 0;
  store_be32(out.data(), static_cast<uint32_t>(n));
  std::memcpy(out.data() + 4, name.data(), name.size());
  out[4 + name.size()] = 0;
  return 4 + n;
}

void write_pos_quat(std::span<uint8_t, kPosQuatBytes> out, int32_t sensor, const double position[3],
                    const double quat_xyzw[4]) {
  uint8_t* p = out.data();
  store_be32(p, static_cast<uint32_t>(sensor));
  store_be32(p + 4, static_cast<uint32_t>(sensor));  // VRPN fills the alignment word the same way
  for (int i = 0; i < 3; ++i) store_be_f64(p + 8 + 8 * i, position[i]);
  for (int i = 0; i < 4; ++i) store_be_f64(p + 32 + 8 * i, quat_xyzw[i]);
}

bool read_pos_quat(std::span<const uint8_t> payload, int32_t& sensor, double position[3], double quat_xyzw[4]) {
  if (payload.size() != kPosQuatBytes) return false;
  const uint8_t* p = payload.data();
  sensor = static_cast<int32_t>(load_be32(p));
  bool finite = true;
  for (int i = 0; i < 3; ++i) finite &= std::isfinite(position[i] = load_be_f64(p + 8 + 8 * i));
  for (int i = 0; i < 4; ++i) finite &= std::isfinite(quat_xyzw[i] = load_be_f64(p + 32 + 8 * i));
  return finite;
}

Parse parse_message(std::span<const uint8_t> in, size_t max_payload, Message& out) {
  if (in.size() < kHeaderBytes) return Parse::need_more;
  const uint32_t len = load_be32(in.data());
  if (len < kHeaderBytes || len - kHeaderBytes > max_payload) return Parse::bad;
  const size_t payload = len - kHeaderBytes;
  const size_t wire = kHeaderBytes + padded(payload);
  if (in.size() < wire) return Parse::need_more;
  out.time = {load_be32(in.data() + 4), load_be32(in.data() + 8)};
  out.sender = static_cast<int32_t>(load_be32(in.data() + 12));
  out.type = static_cast<int32_t>(load_be32(in.data() + 16));
  out.payload = in.subspan(kHeaderBytes, payload);
  out.wire_bytes = wire;
  return Parse::ok;
}

std::string_view description_name(std::span<const uint8_t> payload) {
  if (payload.size() < 5) return {};
  const uint32_t n = load_be32(payload.data());
  if (n < 1 || n > kMaxNameBytes || n > payload.size() - 4) return {};
  const char* s = reinterpret_cast<const char*>(payload.data() + 4);
  return std::string_view(s, strnlen(s, n));
}

}  // namespace mimic::net::vrpn
