// Magellan / SpaceMouse serial protocol (also the serial Spaceball 5000): even-parity nibble
// characters, CR-terminated packets, decoding and encoding, and the mapping of raw values to an
// InputFrame. Pure code with no I/O and no allocation. Reference: docs/device-protocols.md §3.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "mimic/devices/sample.h"

namespace mimic::devices::magellan {

// Nibble 0–15 → its even-parity character ('0' 'A' 'B' '3' 'D' '5' '6' 'G' 'H' '9' ':' 'K' '<'
// 'M' 'N' '?').
char nibble_char(unsigned nibble) noexcept;
// True when `c` is the parity-correct character of nibble c & 0Fh.
bool valid_nibble_char(uint8_t c) noexcept;

// Splits a byte stream at CR. Packets longer than kMaxPacket are dropped and counted; a lone LF
// before a packet is skipped.
class Framer {
 public:
  static constexpr size_t kMaxPacket = 64;
  bool push(uint8_t byte) noexcept;
  std::span<const uint8_t> packet() const noexcept { return {buf_.data(), done_len_}; }
  uint64_t dropped() const noexcept { return dropped_; }
  void reset() noexcept;

 private:
  std::array<uint8_t, kMaxPacket> buf_{};
  size_t len_ = 0;
  size_t done_len_ = 0;
  bool overflow_ = false;
  uint64_t dropped_ = 0;
};

using Axes = std::array<int16_t, 6>;  // X, Y, Z, A (RX), B (RY), C (RZ)

enum class PacketKind : uint8_t {
  none,     // empty, malformed, or a data character with the wrong parity (dropped, as Linux does)
  data,     // d
  keys,     // k
  version,  // v: reply to vQ
  echo,     // z b m n q p c: command echoes
  error,    // e
};

struct Packet {
  PacketKind kind = PacketKind::none;
  Axes axes{};
  // InputFrame convention, bit i = button i+1: keys 1–8 (n1, n2), 9 = '*' (n3 bit 0), 10/11 =
  // Plus XT left/right (n3 bits 1–2), 12 = n3 bit 3 (meaning unknown, kept), 13–16 = the
  // optional 4th nibble.
  uint32_t buttons = 0;
  char echo_type = 0;  // for echo: the command letter
};

// Decodes one packet without its CR.
Packet decode(std::span<const uint8_t> packet) noexcept;

// True for the model words spacenavd looks for in a `v` reply: "MAGELLAN", "SPACEBALL", "CadMan".
bool is_known_version(std::string_view version_text) noexcept;

// --- Encoding (simulator, tests); each returns the packet with its CR. ---
std::array<uint8_t, 26> data_packet(const Axes& axes) noexcept;
// Buttons as Packet::buttons; the 4th nibble (buttons 13–16) is sent only when one of them is
// down.
size_t keys_packet(uint32_t buttons, std::span<uint8_t, 6> out) noexcept;

// --- Values ---
struct Scaling {
  // VRPN saw about ±7200 and divides by 7500; Linux declares ±360. The default follows VRPN.
  float full_scale = 7500.0f;
  int null_radius = 0;
};

// Raw → InputFrame (+X right, +Y up, +Z toward the user). spacenavd negates Magellan Z and RZ to
// match the Spaceball, whose Z we in turn negate, so Magellan axes pass through unchanged.
void to_frame(const Axes& raw, const Scaling& s, InputFrame& out) noexcept;
Axes from_frame(const InputFrame& in, const Scaling& s) noexcept;

}  // namespace mimic::devices::magellan
