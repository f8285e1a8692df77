// "HOST:PORT" as every network option writes it: a name, an IPv4 address or a bracketed IPv6
// address ("[::1]:7777"), then a port 0-65535.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "mimic/core/result.h"

namespace mimic {

struct HostPort {
  std::string host;  // without IPv6 brackets
  uint16_t port = 0;
};

// Fails (invalid_argument, naming the text) without a host or with a port that is not a number
// in range.
Result<HostPort> split_host_port(std::string_view text);

// A port number alone, 0-65535; `what` names it in the error ("port", "VMC port").
Result<uint16_t> parse_port(std::string_view text, std::string_view what = "port");

}  // namespace mimic
