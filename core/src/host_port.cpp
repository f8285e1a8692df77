#include "mimic/core/host_port.h"

#include <charconv>

namespace mimic {

Result<uint16_t> parse_port(std::string_view text, std::string_view what) {
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value > 65535)
    return fail(Errc::invalid_argument, "bad " + std::string(what) + " '" + std::string(text) + "' (expected 0-65535)");
  return static_cast<uint16_t>(value);
}

Result<HostPort> split_host_port(std::string_view text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0 || colon + 1 == text.size())
    return fail(Errc::invalid_argument, "expected ADDR:PORT, got '" + std::string(text) + "'");
  std::string_view host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  auto port = parse_port(text.substr(colon + 1));
  if (!port) return fail(Errc::invalid_argument, port.error().message + " in '" + std::string(text) + "'");
  return HostPort{std::string(host), *port};
}

}  // namespace mimic
