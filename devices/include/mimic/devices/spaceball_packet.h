// Spaceball serial protocol (2003, 3003, 4000 FLX): framing, `^` escaping, packet decoding and
// encoding, and the mapping of raw values to an InputFrame. Pure code: no I/O, no allocation
// on the decode path, so the driver, the simulator, the tests and the fuzzer share it.
// Byte-level reference: docs/device-protocols.md §2.
//
// Wire format: a packet is a type byte, a body, then CR (0Dh). Inside a packet 0Dh, 11h, 13h and
// 5Eh travel as `^M`, `^Q`, `^S`, `^^`. Raw 11h/13h outside an escape are XON/XOFF and carry no
// data; a lone LF before a packet is skipped (some firmware ends the @1 banner line with CR LF).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "mimic/devices/sample.h"

namespace mimic::devices::spaceball {

enum class Model : uint8_t { unknown, sb2003, sb3003, sb4000flx };

// "2003", "3003", "4000 FLX", "unknown".
const char* model_name(Model m) noexcept;

// Splits a byte stream into unescaped packets. Holds at most kMaxPacket bytes; a longer packet
// or a bad escape marks the current packet corrupt: it is dropped at its CR and counted.
class Framer {
 public:
  static constexpr size_t kMaxPacket = 80;  // the longest real packet is the 61-byte @ banner

  // Feeds one byte. True when a complete, clean packet is available through packet(); it stays
  // valid until the next push().
  bool push(uint8_t byte) noexcept;
  std::span<const uint8_t> packet() const noexcept { return {buf_.data(), done_len_}; }

  uint64_t dropped() const noexcept { return dropped_; }  // corrupt packets discarded
  void reset() noexcept;

 private:
  std::array<uint8_t, kMaxPacket> buf_{};
  size_t len_ = 0;
  size_t done_len_ = 0;
  bool escape_ = false;
  bool corrupt_ = false;
  uint64_t dropped_ = 0;
};

// Raw axis order on the wire: TX, TY, TZ, RX, RY, RZ.
using Axes = std::array<int16_t, 6>;

enum class PacketKind : uint8_t {
  none,           // empty, unparseable, or not starting with a printable type (line noise)
  displacement,   // D
  keys,           // K (all models; the 4000 FLX sends it for compatibility)
  advanced_keys,  // . (4000 FLX)
  banner,         // @ line: "@1 Spaceball alive…", "@2 Firmware version…"
  model,          // H: reply to `hm`
  descriptor,     // " : 4000 FLX descriptor lines
  error,          // E
  bad_command,    // ? followed by the rejected command
  echo,           // any other printable type (configuration echoes)
};

struct Packet {
  PacketKind kind = PacketKind::none;
  uint16_t period_16th_ms = 0;   // D: time since the previous D packet, in 1/16 ms
  Axes axes{};                   // D
  uint32_t buttons = 0;          // K / .: InputFrame convention, bit i = button i+1
  bool right_handed = true;      // .: handedness bit
  bool banner_reset = false;     // @1 line (device came out of a reset)
  Model model = Model::unknown;  // H or @2/"… lines that name a model or firmware
  uint16_t firmware_x100 = 0;    // from "Firmware version 2.42" → 242; 0 when absent
  uint16_t error_bits = 0;       // E
};

// Decodes one unescaped packet (type byte + body, no CR). Malformed packets (wrong length for
// their type) give kind none.
Packet decode(std::span<const uint8_t> packet) noexcept;

// Model implied by a firmware version (spacenavd's table): 2.35/2.62/2.63 → 3003;
// 2.43/2.45 → 4000 FLX; 2.02/2.13/2.15/2.42 → 2003. 2.42 is ambiguous (a 4000 FLX can report
// it), so drivers switch to 12 buttons on the first '.' packet.
Model model_from_firmware(uint16_t firmware_x100) noexcept;

// --- Encoding (simulator, tests) ---

// Escapes `body` (type byte + body) into `out` and appends CR. Returns the bytes written, or 0
// when `out` is too small (worst case 2 × body + 1).
size_t encode_packet(std::span<const uint8_t> body, std::span<uint8_t> out) noexcept;

// Unescaped bodies of the binary packets.
std::array<uint8_t, 15> displacement_body(uint16_t period_16th_ms, const Axes& axes) noexcept;
// K packet for `model` from InputFrame buttons (bits the model lacks are ignored).
// `printable` sets bit 6 of each button byte as some firmware may do; decoders ignore it.
std::array<uint8_t, 3> keys_body(Model model, uint32_t buttons, bool printable) noexcept;
// '.' packet (4000 FLX): buttons 1–12 and handedness.
std::array<uint8_t, 3> advanced_keys_body(uint32_t buttons, bool right_handed, bool printable) noexcept;

// --- Values ---

// Raw counts that map to ±1. The sources disagree (Linux declares ±8000 translation and ±1600
// rotation; VRPN divides by 32768); these follow Linux and may be overridden per driver.
struct Scaling {
  float translation_full_scale = 8000.0f;
  float rotation_full_scale = 1600.0f;
  int null_radius = 8;  // |v| <= null_radius reads as 0 (VRPN)
};

// Raw axes → InputFrame axes. The InputFrame frame is right-handed: +X right, +Y up, +Z toward
// the user. Serial Spaceball axis 1 is up/down; TZ and RZ are negated as VRPN does, so that +Z
// points toward the user. Values are clamped to [-1, 1].
void to_frame(const Axes& raw, const Scaling& s, InputFrame& out) noexcept;
// Inverse of to_frame (before clamping and null radius), rounding to the nearest count.
Axes from_frame(const InputFrame& in, const Scaling& s) noexcept;

}  // namespace mimic::devices::spaceball
