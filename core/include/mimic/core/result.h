// Result<T>: the return type of every operation that can fail for an expected reason
// (malformed file, device unplugged, timeout, closed socket). Bugs use assert instead.
#pragma once

#include <string>
#include <utility>

#include <tl/expected.hpp>

namespace mimic {

enum class Errc {
  invalid_argument,  // caller passed something unusable
  parse_error,       // malformed text or binary input; message names where
  io_error,          // file or device could not be read or written
  not_found,         // a named thing (file, joint, device) does not exist
  unsupported,       // valid input that this build cannot handle
  timeout,           // a device or peer did not answer in time
  disconnected,      // a device or peer went away
  out_of_range,      // a value outside its documented range
};

const char* errc_name(Errc code) noexcept;

struct Error {
  Errc code = Errc::invalid_argument;
  std::string message;

  // "parse_error: clip.bvh:12: expected OFFSET"
  std::string what() const { return std::string(errc_name(code)) + ": " + message; }
};

template <class T>
using Result = tl::expected<T, Error>;

using Status = tl::expected<void, Error>;

inline tl::unexpected<Error> fail(Errc code, std::string message) {
  return tl::unexpected<Error>(Error{code, std::move(message)});
}

}  // namespace mimic
