// Text from outside (log headers, peers' avatar and scene names, servers' reject messages) that
// reaches a terminal or a user. Such text may try to drive the terminal (escape sequences, C1
// controls such as CSI 0x9B), reorder what is shown (bidi overrides: "txt.exe" that reads
// "exe.txt"), or hide characters (zero-width spaces: "avat\u200bar1" that looks like
// "avatar1"). docs/security.md lists what is escaped and where.
#pragma once

#include <string>
#include <string_view>

namespace mimic {

// True for a code point that must never reach a terminal as itself: C0 controls and DEL, C1
// controls (U+0080..U+009F), bidirectional controls (U+061C, U+200E/F, U+202A..U+202E,
// U+2066..U+2069), line and paragraph separators, and invisible format characters (soft hyphen,
// zero-width space/joiners, word joiner, invisible operators, BOM, variation selectors, tags,
// Hangul fillers, interlinear annotation).
bool is_unsafe_code_point(char32_t cp) noexcept;

enum class Backslash {
  doubled,  // "a\\b" for "a\b": every escape in the output comes from here (for untrusted text)
  kept,     // for a message that may hold escaped text already (a last defence before printing)
};

// `text` made safe to print: every unsafe code point (above) shown as a visible escape \uXXXX (or
// \UXXXXXXXX above U+FFFF), every byte that is not part of valid UTF-8 (stray continuation bytes,
// overlong forms, surrogates, truncated sequences) as \xNN, and a backslash doubled (by default),
// so an escape in the output always comes from here. Valid printable UTF-8 passes unchanged
// ("Zoë ✓" stays "Zoë ✓").
std::string terminal_safe(std::string_view text, Backslash backslash = Backslash::doubled);

// A name (avatar, scene, publisher) is accepted only if it is valid UTF-8 without any unsafe code
// point: what is shown is then exactly what was sent, and two names that look the same are the
// same bytes as far as invisible characters go.
bool is_safe_name(std::string_view name) noexcept;

}  // namespace mimic
