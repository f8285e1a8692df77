// Emscripten 3.1.6 (Debian 12) ships a libc++ without std::bit_cast; the wire codec uses it.
// Force-included in the WebAssembly build only (web/wasm/CMakeLists.txt).
#pragma once
#include <bit>
#include <type_traits>
#if !defined(__cpp_lib_bit_cast)
namespace std {
template <class To, class From>
constexpr To bit_cast(const From& from) noexcept {
  static_assert(sizeof(To) == sizeof(From) && is_trivially_copyable_v<To> && is_trivially_copyable_v<From>);
  return __builtin_bit_cast(To, from);
}
}  // namespace std
#endif
