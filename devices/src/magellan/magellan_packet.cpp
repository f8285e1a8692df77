#include "mimic/devices/magellan_packet.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace mimic::devices::magellan {

namespace {

constexpr char kNibble[16] = {'0', 'A', 'B', '3', 'D', '5', '6', 'G', 'H', '9', ':', 'K', '<', 'M', 'N', '?'};
constexpr uint8_t kCr = 0x0D;

bool all_valid(std::span<const uint8_t> s) {
  return std::all_of(s.begin(), s.end(), [](uint8_t c) { return valid_nibble_char(c); });
}

int16_t clamp16(float v) { return static_cast<int16_t>(std::clamp(std::round(v), -32768.0f, 32767.0f)); }

float scale(int16_t raw, const Scaling& s) {
  if (std::abs(static_cast<int>(raw)) <= s.null_radius) return 0.0f;
  return std::clamp(static_cast<float>(raw) / s.full_scale, -1.0f, 1.0f);
}

}  // namespace

char nibble_char(unsigned n) noexcept { return kNibble[n & 0xF]; }

bool valid_nibble_char(uint8_t c) noexcept { return static_cast<uint8_t>(kNibble[c & 0xF]) == c; }

void Framer::reset() noexcept {
  len_ = 0;
  done_len_ = 0;
  overflow_ = false;
}

bool Framer::push(uint8_t b) noexcept {
  if (b == kCr) {
    const size_t n = len_;
    const bool over = overflow_;
    len_ = 0;
    overflow_ = false;
    if (over) {
      ++dropped_;
      return false;
    }
    if (n == 0) return false;
    done_len_ = n;
    return true;
  }
  if (b == 0x0A && len_ == 0) return false;
  if (len_ < buf_.size())
    buf_[len_++] = b;
  else
    overflow_ = true;
  return false;
}

Packet decode(std::span<const uint8_t> p) noexcept {
  Packet out;
  if (p.empty()) return out;
  const auto body = p.subspan(1);
  switch (p[0]) {
    case 'd': {
      if (body.size() != 24 || !all_valid(body)) return out;
      for (size_t a = 0; a < 6; ++a) {
        unsigned v = 0;
        for (size_t k = 0; k < 4; ++k) v = (v << 4) | (body[4 * a + k] & 0xFu);
        out.axes[a] = static_cast<int16_t>(static_cast<int>(v) - 32768);
      }
      out.kind = PacketKind::data;
      return out;
    }
    case 'k': {
      if ((body.size() != 3 && body.size() != 4) || !all_valid(body)) return out;
      const unsigned n1 = body[0] & 0xFu, n2 = body[1] & 0xFu, n3 = body[2] & 0xFu;
      uint32_t m = n1 | n2 << 4 | n3 << 8;
      if (body.size() == 4) m |= static_cast<uint32_t>(body[3] & 0xFu) << 12;
      out.kind = PacketKind::keys;
      out.buttons = m;
      return out;
    }
    case 'v': out.kind = PacketKind::version; return out;
    case 'z':
    case 'b':
    case 'm':
    case 'n':
    case 'q':
    case 'p':
    case 'c':
      out.kind = PacketKind::echo;
      out.echo_type = static_cast<char>(p[0]);
      return out;
    case 'e': out.kind = PacketKind::error; return out;
    default: return out;
  }
}

bool is_known_version(std::string_view v) noexcept {
  return v.find("MAGELLAN") != std::string_view::npos || v.find("SPACEBALL") != std::string_view::npos ||
         v.find("CadMan") != std::string_view::npos;
}

std::array<uint8_t, 26> data_packet(const Axes& axes) noexcept {
  std::array<uint8_t, 26> b{};
  b[0] = 'd';
  for (size_t a = 0; a < 6; ++a) {
    const unsigned v = static_cast<unsigned>(axes[a] + 32768);
    for (size_t k = 0; k < 4; ++k) b[1 + 4 * a + k] = static_cast<uint8_t>(nibble_char(v >> (12 - 4 * k)));
  }
  b[25] = kCr;
  return b;
}

size_t keys_packet(uint32_t buttons, std::span<uint8_t, 6> out) noexcept {
  size_t n = 0;
  out[n++] = 'k';
  out[n++] = static_cast<uint8_t>(nibble_char(buttons & 0xFu));
  out[n++] = static_cast<uint8_t>(nibble_char((buttons >> 4) & 0xFu));
  out[n++] = static_cast<uint8_t>(nibble_char((buttons >> 8) & 0xFu));
  if (buttons & (0xFu << 12)) out[n++] = static_cast<uint8_t>(nibble_char((buttons >> 12) & 0xFu));
  out[n++] = kCr;
  return n;
}

void to_frame(const Axes& raw, const Scaling& s, InputFrame& out) noexcept {
  out.translation = {scale(raw[0], s), scale(raw[1], s), scale(raw[2], s)};
  out.rotation = {scale(raw[3], s), scale(raw[4], s), scale(raw[5], s)};
}

Axes from_frame(const InputFrame& in, const Scaling& s) noexcept {
  const float f = s.full_scale;
  return {clamp16(in.translation.x * f), clamp16(in.translation.y * f), clamp16(in.translation.z * f),
          clamp16(in.rotation.x * f),    clamp16(in.rotation.y * f),    clamp16(in.rotation.z * f)};
}

}  // namespace mimic::devices::magellan
