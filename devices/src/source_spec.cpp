// Source specs: "<scheme>:<target>?<key>=<value>&...". Each scheme lists the keys it knows and
// how to check their values, so a typo ("brids=4") is an error that names the known keys rather
// than a silently ignored option. Drivers add their keys to kSchemes.
#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <string>

#include "mimic/devices/source.h"

namespace mimic::devices {

namespace {

enum class Kind { any, integer, number, boolean, baud, choice };

struct KeySpec {
  const char* key;
  Kind kind;
  long min = 0, max = 0;          // integer bounds (inclusive) when max > min
  const char* choices = nullptr;  // '|'-separated for Kind::choice
};

struct SchemeSpec {
  const char* scheme;
  bool needs_target;
  const char* target_what;  // for messages: "a serial device path", "a motion name", ...
  std::initializer_list<KeySpec> keys;
};

const SchemeSpec kSchemes[] = {
    {"flock",
     true,
     "a serial device path",
     {{"birds", Kind::integer, 1, 14},
      {"baud", Kind::baud},
      {"erc", Kind::boolean},
      {"format", Kind::choice, 0, 0,
       "position|angles|matrix|position_angles|position_matrix|quaternion|position_quaternion|"
       "pos|ang|mat|pos_angles|pos_matrix|quat|pos_quat"},
      {"mode", Kind::choice, 0, 0, "stream|point"},
      {"hemisphere", Kind::choice, 0, 0, "forward|aft|upper|lower|left|right"},
      {"rate", Kind::number, 14, 144},
      {"report", Kind::choice, 0, 0, "1|2|8|32"},
      {"range", Kind::choice, 0, 0, "36|72"},
      {"button", Kind::boolean},
      {"group", Kind::boolean},
      {"timeout_ms", Kind::integer, 10, 60000}}},
    {"spaceball",
     true,
     "a serial device path",
     {{"baud", Kind::baud},
      {"probe", Kind::number, 0, 60},
      {"dead", Kind::number, 0, 600},
      {"reset", Kind::number, 0, 60},
      {"tscale", Kind::number, 1, 32768},
      {"rscale", Kind::number, 1, 32768},
      {"null", Kind::integer, 0, 1000}}},
    {"magellan",
     true,
     "a serial device path",
     {{"baud", Kind::baud},
      {"settle", Kind::number, 0, 60},
      {"probe", Kind::number, 0, 60},
      {"dead", Kind::number, 0, 600},
      {"scale", Kind::number, 1, 32768},
      {"null", Kind::integer, 0, 1000}}},
    {"spacemouse",
     false,
     "a hidraw path, 'sim' or empty",
     {{"vid", Kind::any}, {"pid", Kind::any}, {"seed", Kind::integer, 0, 0x7FFFFFFF}}},
    // sim/bvh/replay keys are interpreted by sim/src/open_source*.cpp (docs/log-format.md).
    {"sim",
     false,
     "a motion name or empty",
     {{"seed", Kind::integer, 0, 0x7FFFFFFF},
      {"rate", Kind::number, 1, 10000},
      {"sensors", Kind::choice, 0, 0, "3|6|11|all"},
      {"noise_mm", Kind::number, 0, 1000},
      {"noise_deg", Kind::number, 0, 180},
      {"drift_mm", Kind::number, 0, 1000},
      {"drift_deg", Kind::number, 0, 180},
      {"latency_ms", Kind::number, 0, 10000},
      {"dropout", Kind::number, 0, 1},
      {"burst", Kind::integer, 1, 100000},
      {"body", Kind::any}}},
    // vmc keys are interpreted by service/src/vmc_feed.cpp (docs/hardware.md).
    {"vmc",
     true,
     "[HOST:]PORT to listen on (VMC performer data)",
     {{"stale_ms", Kind::integer, 10, 60000}, {"map", Kind::any}}},
    // vrpn and osc-trackers keys are interpreted by service/src/vrpn_source.cpp and
    // osc_tracker_source.cpp (docs/hardware.md).
    {"vrpn",
     true,
     "DEVICE@HOST[:PORT] or DEVICE@tcp://HOST[:PORT] (a VRPN tracker)",
     {{"layout", Kind::choice, 0, 0, "3|6|11|all"},
      {"devices", Kind::any},
      {"map", Kind::any},
      {"axes", Kind::any},
      {"scale", Kind::number, 0, 1000000},
      {"buttons", Kind::any},
      {"stale_ms", Kind::integer, 10, 60000}}},
    {"osc-trackers",
     true,
     "[HOST:]PORT to listen on (VRChat-style OSC trackers)",
     {{"map", Kind::any}, {"stale_ms", Kind::integer, 10, 60000}}},
    {"replay",
     true,
     "a log file path",
     {{"speed", Kind::number, 0, 1000000}, {"loop", Kind::boolean}, {"from", Kind::number, 0, 1000000000}}},
    {"bvh",
     true,
     "a BVH file path",
     {{"seed", Kind::integer, 0, 0x7FFFFFFF},
      {"rate", Kind::number, 1, 10000},
      {"sensors", Kind::choice, 0, 0, "3|6|11|all"},
      {"noise_mm", Kind::number, 0, 1000},
      {"noise_deg", Kind::number, 0, 180},
      {"drift_mm", Kind::number, 0, 1000},
      {"drift_deg", Kind::number, 0, 180},
      {"latency_ms", Kind::number, 0, 10000},
      {"dropout", Kind::number, 0, 1},
      {"burst", Kind::integer, 1, 100000},
      {"body", Kind::any},
      {"loop", Kind::boolean}}},
};

std::string scheme_list() {
  std::string s;
  for (const auto& sc : kSchemes) {
    if (!s.empty()) s += ", ";
    s += sc.scheme;
  }
  return s;
}

std::string key_list(const SchemeSpec& sc) {
  std::string s;
  for (const auto& k : sc.keys) {
    if (!s.empty()) s += ", ";
    s += k.key;
  }
  return s.empty() ? "none" : s;
}

bool parse_long(const std::string& v, long& out) {
  auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
  return ec == std::errc() && p == v.data() + v.size() && !v.empty();
}

bool parse_double(const std::string& v, double& out) {
  if (v.empty()) return false;
  char* end = nullptr;
  out = std::strtod(v.c_str(), &end);
  return end == v.c_str() + v.size();
}

bool in_choices(const char* choices, const std::string& v) {
  std::string_view rest(choices);
  while (!rest.empty()) {
    const size_t bar = rest.find('|');
    if (rest.substr(0, bar) == v) return true;
    if (bar == std::string_view::npos) break;
    rest.remove_prefix(bar + 1);
  }
  return false;
}

// Empty string when the value fits the key, else the reason.
std::string check_value(const KeySpec& k, const std::string& v) {
  switch (k.kind) {
    case Kind::any: return {};
    case Kind::integer: {
      long n = 0;
      if (!parse_long(v, n)) return "expects an integer";
      if (k.max > k.min && (n < k.min || n > k.max))
        return "must be in " + std::to_string(k.min) + ".." + std::to_string(k.max);
      return {};
    }
    case Kind::number: {
      double d = 0;
      if (!parse_double(v, d)) return "expects a number";
      if (k.max > k.min && (d < static_cast<double>(k.min) || d > static_cast<double>(k.max)))
        return "must be in " + std::to_string(k.min) + ".." + std::to_string(k.max);
      return {};
    }
    case Kind::boolean:
      if (in_choices("0|1|true|false|yes|no|on|off", v)) return {};
      return "expects a boolean (0/1, true/false, yes/no, on/off)";
    case Kind::baud:
      if (in_choices("2400|4800|9600|19200|38400|57600|115200", v)) return {};
      return "expects one of 2400, 4800, 9600, 19200, 38400, 57600, 115200";
    case Kind::choice:
      if (in_choices(k.choices, v)) return {};
      {
        std::string c = k.choices;
        std::replace(c.begin(), c.end(), '|', ',');
        return "expects one of " + c;
      }
  }
  return {};
}

}  // namespace

Result<SourceSpec> parse_source_spec(std::string_view text) {
  SourceSpec spec;
  spec.text = std::string(text);
  const std::string quoted = "'" + spec.text + "'";
  if (text.empty()) return fail(Errc::invalid_argument, "empty source spec (expected <scheme>:<target>)");

  const size_t colon = text.find(':');
  const size_t query = text.find('?');
  std::string_view scheme_part = text.substr(0, std::min(colon, query));
  spec.scheme = std::string(scheme_part);
  const SchemeSpec* sc = nullptr;
  for (const auto& s : kSchemes)
    if (spec.scheme == s.scheme) sc = &s;
  if (!sc) {
    return fail(Errc::invalid_argument,
                "source " + quoted + ": unknown scheme '" + spec.scheme + "' (known: " + scheme_list() + ")");
  }

  std::string_view rest;
  if (colon != std::string_view::npos && (query == std::string_view::npos || colon < query))
    rest = text.substr(colon + 1);
  else if (query != std::string_view::npos)
    rest = text.substr(query);
  const size_t q = rest.find('?');
  spec.target = std::string(rest.substr(0, q));
  if (sc->needs_target && spec.target.empty()) {
    return fail(Errc::invalid_argument, "source " + quoted + ": scheme '" + spec.scheme + "' needs " + sc->target_what +
                                            " (e.g. " + spec.scheme + ":<target>)");
  }

  if (q != std::string_view::npos) {
    std::string_view params = rest.substr(q + 1);
    if (params.empty()) return fail(Errc::invalid_argument, "source " + quoted + ": nothing after '?'");
    while (true) {
      const size_t amp = params.find('&');
      std::string_view item = params.substr(0, amp);
      const size_t eq = item.find('=');
      if (item.empty()) return fail(Errc::invalid_argument, "source " + quoted + ": empty parameter (stray '&')");
      if (eq == std::string_view::npos || eq == 0) {
        return fail(Errc::invalid_argument,
                    "source " + quoted + ": parameter '" + std::string(item) + "' is not key=value");
      }
      std::string key(item.substr(0, eq)), value(item.substr(eq + 1));
      if (value.empty())
        return fail(Errc::invalid_argument, "source " + quoted + ": parameter '" + key + "' has no value");
      const KeySpec* ks = nullptr;
      for (const auto& k : sc->keys)
        if (key == k.key) ks = &k;
      if (!ks) {
        return fail(Errc::invalid_argument, "source " + quoted + ": unknown parameter '" + key + "' for " +
                                                spec.scheme + " (known: " + key_list(*sc) + ")");
      }
      if (spec.params.count(key))
        return fail(Errc::invalid_argument, "source " + quoted + ": parameter '" + key + "' given twice");
      if (auto why = check_value(*ks, value); !why.empty()) {
        return fail(Errc::out_of_range, "source " + quoted + ": " + key + "=" + value + ": " + why);
      }
      spec.params.emplace(std::move(key), std::move(value));
      if (amp == std::string_view::npos) break;
      params.remove_prefix(amp + 1);
    }
  }
  return spec;
}

}  // namespace mimic::devices
