// libFuzzer entry point for the terminal-safe text function and the name check: whatever the
// bytes, the output is valid UTF-8 without any control, C1, bidi or invisible character (a safe
// name), never shorter than the input, unchanged by a second pass when backslashes are kept; a
// name the check accepts (without backslashes) is printed as itself.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "mimic/core/text.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  for (const auto mode : {mimic::Backslash::doubled, mimic::Backslash::kept}) {
    const std::string out = mimic::terminal_safe(text, mode);
    if (!mimic::is_safe_name(out)) std::abort();
    for (const char ch : out)
      if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7F) std::abort();
    // Escaping never shrinks the text and is idempotent when backslashes are kept.
    if (out.size() < size) std::abort();
    if (mode == mimic::Backslash::kept && mimic::terminal_safe(out, mode) != out) std::abort();
  }
  if (mimic::is_safe_name(text) && text.find('\\') == std::string_view::npos && mimic::terminal_safe(text) != text)
    std::abort();
  return 0;
}
