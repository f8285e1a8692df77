#include "mimic/devices/spaceball_packet.h"

#include <algorithm>
#include <cmath>
#include <string_view>

namespace mimic::devices::spaceball {

namespace {

constexpr uint8_t kCr = 0x0D;
constexpr uint8_t kLf = 0x0A;
constexpr uint8_t kXon = 0x11;
constexpr uint8_t kXoff = 0x13;
constexpr uint8_t kCaret = 0x5E;

bool needs_escape(uint8_t b) { return b == kCr || b == kXon || b == kXoff || b == kCaret; }

uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

std::string_view as_text(std::span<const uint8_t> p) { return {reinterpret_cast<const char*>(p.data()), p.size()}; }

// "… version 2.42 …" or "V2.42": the first d.dd after `key` → 242; 0 when absent.
uint16_t parse_version(std::string_view text, std::string_view key) {
  size_t at = text.find(key);
  if (at == std::string_view::npos) return 0;
  at += key.size();
  while (at < text.size() && text[at] == ' ') ++at;
  if (at + 4 > text.size()) return 0;
  const char a = text[at], dot = text[at + 1], b = text[at + 2], c = text[at + 3];
  auto digit = [](char ch) { return ch >= '0' && ch <= '9'; };
  if (!digit(a) || dot != '.' || !digit(b) || !digit(c)) return 0;
  return static_cast<uint16_t>((a - '0') * 100 + (b - '0') * 10 + (c - '0'));
}

int16_t clamp16(float v) {
  const float r = std::round(v);
  return static_cast<int16_t>(std::clamp(r, -32768.0f, 32767.0f));
}

float scale(int16_t raw, float full, int null_radius) {
  if (std::abs(static_cast<int>(raw)) <= null_radius) return 0.0f;
  return std::clamp(static_cast<float>(raw) / full, -1.0f, 1.0f);
}

}  // namespace

const char* model_name(Model m) noexcept {
  switch (m) {
    case Model::sb2003: return "2003";
    case Model::sb3003: return "3003";
    case Model::sb4000flx: return "4000 FLX";
    case Model::unknown: break;
  }
  return "unknown";
}

void Framer::reset() noexcept {
  len_ = 0;
  done_len_ = 0;
  escape_ = false;
  corrupt_ = false;
}

bool Framer::push(uint8_t b) noexcept {
  if (b == kCr) {
    // A raw CR always ends the packet, even after a dangling '^'.
    const bool clean = !corrupt_ && !escape_;
    const size_t n = len_;
    if (!clean) ++dropped_;
    len_ = 0;
    escape_ = false;
    corrupt_ = false;
    if (!clean || n == 0) return false;
    done_len_ = n;
    return true;
  }
  if (escape_) {
    escape_ = false;
    uint8_t v;
    if (b == kCaret) {
      v = kCaret;
    } else if (b == 'M' || b == 'Q' || b == 'S') {
      v = static_cast<uint8_t>(b & 0x1F);
    } else {
      corrupt_ = true;  // decoders disagree on what this means, so the packet is not trusted
      return false;
    }
    if (len_ < buf_.size())
      buf_[len_++] = v;
    else
      corrupt_ = true;
    return false;
  }
  if (b == kXon || b == kXoff) return false;  // flow control, never data
  if (b == kLf && len_ == 0) return false;    // CR LF line ends
  if (b == kCaret) {
    escape_ = true;
    return false;
  }
  if (len_ < buf_.size())
    buf_[len_++] = b;
  else
    corrupt_ = true;
  return false;
}

Model model_from_firmware(uint16_t fw) noexcept {
  switch (fw) {
    case 235:
    case 262:
    case 263: return Model::sb3003;
    case 243:
    case 245: return Model::sb4000flx;
    case 202:
    case 213:
    case 215:
    case 242: return Model::sb2003;
    default: return Model::unknown;
  }
}

Packet decode(std::span<const uint8_t> p) noexcept {
  Packet out;
  if (p.empty()) return out;
  const uint8_t type = p[0];
  const std::string_view text = as_text(p);
  switch (type) {
    case 'D': {
      if (p.size() != 15) return out;
      out.kind = PacketKind::displacement;
      out.period_16th_ms = be16(&p[1]);
      for (size_t i = 0; i < 6; ++i) out.axes[i] = static_cast<int16_t>(be16(&p[3 + 2 * i]));
      return out;
    }
    case 'K': {
      if (p.size() != 3) return out;
      const uint8_t b1 = p[1], b2 = p[2];
      uint32_t m = b2 & 0x0Fu;                     // buttons 1–4
      if (b2 & 0x10) m |= 1u << 0;                 // 3003 left
      if (b2 & 0x20) m |= 1u << 1;                 // 3003 right
      m |= static_cast<uint32_t>(b1 & 0x07) << 4;  // buttons 5–7
      if (b1 & 0x28) m |= 1u << 7;                 // rezero: 2003 (08h) or 3003 (20h)
      if (b1 & 0x10) m |= 1u << 8;                 // 2003 pick button
      out.kind = PacketKind::keys;
      out.buttons = m;
      return out;
    }
    case '.': {
      if (p.size() != 3) return out;
      const uint8_t b1 = p[1], b2 = p[2];
      uint32_t m = b2 & 0x3Fu;                     // buttons 1–6
      if (b2 & 0x80) m |= 1u << 6;                 // button 7
      m |= static_cast<uint32_t>(b1 & 0x1F) << 7;  // buttons 8–12
      out.kind = PacketKind::advanced_keys;
      out.buttons = m;
      out.right_handed = (b1 & 0x20) != 0;
      out.model = Model::sb4000flx;
      return out;
    }
    case '@': {
      out.kind = PacketKind::banner;
      out.banner_reset = text.substr(0, 2) == "@1";
      out.firmware_x100 = parse_version(text, "ersion");
      out.model = model_from_firmware(out.firmware_x100);
      return out;
    }
    case 'H': {
      out.kind = PacketKind::model;
      if (text.substr(0, 2) == "Hm") {
        if (text.find("3003") != std::string_view::npos)
          out.model = Model::sb3003;
        else if (text.find("2003") != std::string_view::npos)
          out.model = Model::sb2003;
        else if (text.find("4000") != std::string_view::npos)
          out.model = Model::sb4000flx;
      } else if (text.substr(0, 2) == "Hv") {
        // Only the 4000 FLX answers `hm` with its firmware line.
        out.model = Model::sb4000flx;
        out.firmware_x100 = parse_version(text, "ersion");
      }
      return out;
    }
    case '"': {
      out.kind = PacketKind::descriptor;
      if (text.find("4000") != std::string_view::npos) out.model = Model::sb4000flx;
      if (text.substr(0, 2) == "\"2") out.right_handed = text.find(" L ") == std::string_view::npos;
      if (text.substr(0, 2) == "\"3") out.firmware_x100 = parse_version(text, "V");
      return out;
    }
    case 'E': {
      out.kind = PacketKind::error;
      const auto body = p.subspan(1);
      const bool letters =
          !body.empty() && std::all_of(body.begin(), body.end(), [](uint8_t c) { return c >= '@' && c <= 'H'; });
      if (letters) {
        for (uint8_t c : body) out.error_bits = static_cast<uint16_t>(out.error_bits | (1u << (c - '@')));
      } else if (body.size() == 2) {
        out.error_bits = be16(body.data());
      }
      return out;
    }
    case '?': out.kind = PacketKind::bad_command; return out;
    default:
      // Replies start with a printable command letter; anything else is line noise.
      if (type >= 0x20 && type < 0x7F) out.kind = PacketKind::echo;
      return out;
  }
}

size_t encode_packet(std::span<const uint8_t> body, std::span<uint8_t> out) noexcept {
  size_t n = 0;
  for (uint8_t b : body) {
    if (needs_escape(b)) {
      if (n + 2 > out.size()) return 0;
      out[n++] = kCaret;
      out[n++] = b == kCaret ? kCaret : static_cast<uint8_t>(b | 0x40);
    } else {
      if (n + 1 > out.size()) return 0;
      out[n++] = b;
    }
  }
  if (n + 1 > out.size()) return 0;
  out[n++] = kCr;
  return n;
}

std::array<uint8_t, 15> displacement_body(uint16_t period, const Axes& axes) noexcept {
  std::array<uint8_t, 15> b{};
  b[0] = 'D';
  b[1] = static_cast<uint8_t>(period >> 8);
  b[2] = static_cast<uint8_t>(period & 0xFF);
  for (size_t i = 0; i < 6; ++i) {
    const auto v = static_cast<uint16_t>(axes[i]);
    b[3 + 2 * i] = static_cast<uint8_t>(v >> 8);
    b[4 + 2 * i] = static_cast<uint8_t>(v & 0xFF);
  }
  return b;
}

std::array<uint8_t, 3> keys_body(Model model, uint32_t buttons, bool printable) noexcept {
  auto bit = [&](int i) { return (buttons >> i) & 1u; };
  uint32_t b1 = 0, b2 = 0;
  if (model == Model::sb3003) {
    b2 = bit(0) << 4 | bit(1) << 5;
    b1 = bit(7) << 5;
  } else {
    b2 = buttons & 0x0Fu;
    b1 = (buttons >> 4) & 0x07u;
    b1 |= bit(7) << 3;
    if (model != Model::sb4000flx) b1 |= bit(8) << 4;  // the pick button is a 2003 part
  }
  if (printable) {
    b1 |= 0x40;
    b2 |= 0x40;
  }
  return {'K', static_cast<uint8_t>(b1), static_cast<uint8_t>(b2)};
}

std::array<uint8_t, 3> advanced_keys_body(uint32_t buttons, bool right_handed, bool printable) noexcept {
  uint32_t b2 = (buttons & 0x3Fu) | ((buttons >> 6) & 1u) << 7;
  uint32_t b1 = (buttons >> 7) & 0x1Fu;
  if (right_handed) b1 |= 0x20;
  if (printable) {
    b1 |= 0x40;
    b2 |= 0x40;
  }
  return {'.', static_cast<uint8_t>(b1), static_cast<uint8_t>(b2)};
}

void to_frame(const Axes& raw, const Scaling& s, InputFrame& out) noexcept {
  const float ts = s.translation_full_scale, rs = s.rotation_full_scale;
  const int nr = s.null_radius;
  out.translation = {scale(raw[0], ts, nr), scale(raw[1], ts, nr), -scale(raw[2], ts, nr)};
  out.rotation = {scale(raw[3], rs, nr), scale(raw[4], rs, nr), -scale(raw[5], rs, nr)};
}

Axes from_frame(const InputFrame& in, const Scaling& s) noexcept {
  const float ts = s.translation_full_scale, rs = s.rotation_full_scale;
  return {clamp16(in.translation.x * ts), clamp16(in.translation.y * ts), clamp16(-in.translation.z * ts),
          clamp16(in.rotation.x * rs),    clamp16(in.rotation.y * rs),    clamp16(-in.rotation.z * rs)};
}

}  // namespace mimic::devices::spaceball
