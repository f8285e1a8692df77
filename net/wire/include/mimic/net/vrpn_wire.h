// VRPN's wire format, version 07 (vrpn_Connection.C; the cookie "vrpn: ver. 07.35"). Pure
// encoders and a message parser; no I/O.
//
// Every message: a 24-byte header of big-endian 32-bit words (length = 24 + payload length,
// unpadded; time seconds; time microseconds; sender id; type id; a sequence number in the
// header's padding word), then the payload, zero-padded to a multiple of 8 bytes. System
// messages have negative types: -1 sender description, -2 type description (payload: u32
// strlen(name) + 1, then the name with its NUL; the id travels in the sender field), -3 UDP
// description (sender field = UDP port, payload = the host's address as a NUL-terminated
// string), -4 log description. A vrpn_Tracker position report ("vrpn_Tracker Pos_Quat") is
// i32 sensor, i32 padding, f64 x y z, f64 qx qy qz qw, all big-endian: 64 bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace mimic::net::vrpn {

inline constexpr size_t kCookieBytes = 24;
inline constexpr size_t kHeaderBytes = 24;
inline constexpr size_t kPosQuatBytes = 64;
inline constexpr size_t kMaxNameBytes = 100;       // vrpn_CNAME, NUL included
inline constexpr size_t kUdpDatagramBytes = 1472;  // vrpn_CONNECTION_UDP_BUFLEN
inline constexpr int32_t kSenderDescription = -1;
inline constexpr int32_t kTypeDescription = -2;
inline constexpr int32_t kUdpDescription = -3;
inline constexpr int32_t kLogDescription = -4;

struct Timestamp {
  uint32_t seconds = 0;
  uint32_t microseconds = 0;
};
Timestamp timestamp_from_seconds(double unix_s);

constexpr size_t padded(size_t n) { return (n + 7) & ~size_t(7); }
constexpr size_t message_bytes(size_t payload) { return kHeaderBytes + padded(payload); }

// Our cookie: "vrpn: ver. 07.35", two spaces, the remote log mode '0', zero padding.
void write_cookie(std::span<uint8_t, kCookieBytes> out);
// True when `cookie` is a VRPN 07.x cookie (minor versions interoperate, as VRPN itself allows)
// with a log mode '0'..'3'.
bool cookie_ok(std::span<const uint8_t, kCookieBytes> cookie);

// Writes one message (header + padded payload) at `out`; returns the bytes written, 0 when it
// does not fit.
size_t write_message(std::span<uint8_t> out, Timestamp time, int32_t sender, int32_t type, uint32_t sequence,
                     std::span<const uint8_t> payload);
// The payload of a sender or type description: u32 strlen + 1, name, NUL. 0 if it does not fit.
size_t write_description(std::span<uint8_t> out, std::string_view name);
// A Pos_Quat payload (64 bytes). Quaternion in (x, y, z, w) order, as VRPN's quatlib.
void write_pos_quat(std::span<uint8_t, kPosQuatBytes> out, int32_t sensor, const double position[3],
                    const double quat_xyzw[4]);

struct Message {
  Timestamp time;
  int32_t sender = 0;
  int32_t type = 0;
  std::span<const uint8_t> payload;  // unpadded
  size_t wire_bytes = 0;             // header + padded payload
};
enum class Parse { ok, need_more, bad };
// Parses the message at the start of `in`. `bad`: a length below the header or above
// `max_payload`.
Parse parse_message(std::span<const uint8_t> in, size_t max_payload, Message& out);

// A Pos_Quat payload read back; false when it is not 64 bytes or holds a non-finite number.
bool read_pos_quat(std::span<const uint8_t> payload, int32_t& sensor, double position[3], double quat_xyzw[4]);

// The name in a sender/type description payload, or empty when malformed.
std::string_view description_name(std::span<const uint8_t> payload);

uint32_t load_be32(const uint8_t* p);
void store_be32(uint8_t* p, uint32_t v);
void store_be_f64(uint8_t* p, double v);
double load_be_f64(const uint8_t* p);

}  // namespace mimic::net::vrpn
