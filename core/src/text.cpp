#include "mimic/core/text.h"

#include <cstdint>

namespace mimic {
namespace {

// Decodes one UTF-8 sequence at text[i] strictly (RFC 3629: no overlong forms, no surrogates,
// nothing above U+10FFFF). Returns its length, or 0 when the bytes there are not valid UTF-8.
size_t decode_utf8(std::string_view text, size_t i, char32_t& cp) noexcept {
  const auto b = [&](size_t k) { return static_cast<uint8_t>(text[i + k]); };
  const size_t left = text.size() - i;
  const uint8_t c = b(0);
  if (c < 0x80) {
    cp = c;
    return 1;
  }
  size_t n = 0;
  uint8_t lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;  // overlong
    if (c == 0xED) hi = 0x9F;  // surrogates
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;  // overlong
    if (c == 0xF4) hi = 0x8F;  // above U+10FFFF
  } else {
    return 0;  // a stray continuation byte, C0/C1 lead (overlong) or F5..FF
  }
  if (left < n || b(1) < lo || b(1) > hi) return 0;
  char32_t v = c & (n == 2 ? 0x1F : n == 3 ? 0x0F : 0x07);
  for (size_t k = 1; k < n; ++k) {
    if ((b(k) & 0xC0) != 0x80) return 0;
    v = (v << 6) | (b(k) & 0x3F);
  }
  cp = v;
  return n;
}

void append_hex(std::string& out, uint32_t v, int digits) {
  static constexpr char kHex[] = "0123456789abcdef";
  for (int shift = (digits - 1) * 4; shift >= 0; shift -= 4) out += kHex[(v >> shift) & 15];
}

}  // namespace

bool is_unsafe_code_point(char32_t cp) noexcept {
  if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F)) return true;  // C0, DEL, C1
  if (cp < 0xAD) return false;
  switch (cp) {
    case 0x00AD:  // soft hyphen
    case 0x034F:  // combining grapheme joiner
    case 0x061C:  // Arabic letter mark (bidi)
    case 0x115F:
    case 0x1160:  // Hangul fillers (blank)
    case 0x17B4:
    case 0x17B5:  // Khmer inherent vowels (invisible)
    case 0x3164:  // Hangul filler
    case 0xFEFF:  // zero-width no-break space (BOM)
    case 0xFFA0:  // halfwidth Hangul filler
    case 0xFFFE:
    case 0xFFFF:  // noncharacters
      return true;
    default: break;
  }
  return (cp >= 0x180B && cp <= 0x180F) ||    // Mongolian variation selectors and vowel separator
         (cp >= 0x200B && cp <= 0x200F) ||    // zero-width space, ZWNJ, ZWJ, LRM, RLM
         (cp >= 0x2028 && cp <= 0x202E) ||    // line/paragraph separators, bidi embeddings/overrides
         (cp >= 0x2060 && cp <= 0x206F) ||    // word joiner, invisible operators, bidi isolates
         (cp >= 0xFE00 && cp <= 0xFE0F) ||    // variation selectors
         (cp >= 0xFFF9 && cp <= 0xFFFB) ||    // interlinear annotation
         (cp >= 0x1D173 && cp <= 0x1D17A) ||  // musical format controls
         (cp >= 0xE0000 && cp <= 0xE0FFF);    // tags, variation selectors supplement
}

std::string terminal_safe(std::string_view text, Backslash backslash) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const size_t n = decode_utf8(text, i, cp);
    if (n == 0) {
      // Not UTF-8: this byte alone, as itself in hex; decoding resumes at the next byte.
      out += "\\x";
      append_hex(out, static_cast<uint8_t>(text[i]), 2);
      ++i;
      continue;
    }
    if (cp == '\\' && backslash == Backslash::doubled) {
      out += "\\\\";
    } else if (is_unsafe_code_point(cp)) {
      out += cp > 0xFFFF ? "\\U" : "\\u";
      append_hex(out, static_cast<uint32_t>(cp), cp > 0xFFFF ? 8 : 4);
    } else {
      out.append(text.substr(i, n));
    }
    i += n;
  }
  return out;
}

bool is_safe_name(std::string_view name) noexcept {
  for (size_t i = 0; i < name.size();) {
    char32_t cp = 0;
    const size_t n = decode_utf8(name, i, cp);
    if (n == 0 || is_unsafe_code_point(cp)) return false;
    i += n;
  }
  return true;
}

}  // namespace mimic
