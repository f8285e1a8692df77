#include "mimic/core/result.h"

namespace mimic {

const char* errc_name(Errc code) noexcept {
  switch (code) {
    case Errc::invalid_argument: return "invalid argument";
    case Errc::parse_error: return "parse error";
    case Errc::io_error: return "i/o error";
    case Errc::not_found: return "not found";
    case Errc::unsupported: return "unsupported";
    case Errc::timeout: return "timeout";
    case Errc::disconnected: return "disconnected";
    case Errc::out_of_range: return "out of range";
  }
  return "error";
}

}  // namespace mimic
