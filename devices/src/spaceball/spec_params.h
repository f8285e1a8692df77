// Reads typed parameters out of a SourceSpec and reports the first bad or unknown one.
#pragma once

#include <cerrno>
#include <cstdlib>
#include <set>
#include <string>

#include "mimic/devices/source.h"

namespace mimic::devices::detail {

class SpecParams {
 public:
  explicit SpecParams(const SourceSpec& spec) : spec_(spec) {}

  void double_param(const std::string& key, double& out) {
    if (const auto* v = find(key)) {
      char* end = nullptr;
      errno = 0;
      const double d = std::strtod(v->c_str(), &end);
      if (v->empty() || *end != '\0' || errno != 0 || !(d >= 0))
        bad(key, *v, "a non-negative number");
      else
        out = d;
    }
  }
  void float_param(const std::string& key, float& out) {
    double d = out;
    double_param(key, d);
    out = static_cast<float>(d);
  }
  void int_param(const std::string& key, int& out) {
    if (const auto* v = find(key)) {
      char* end = nullptr;
      const long l = std::strtol(v->c_str(), &end, 10);
      if (v->empty() || *end != '\0' || l < 0 || l > 32767)
        bad(key, *v, "an integer 0-32767");
      else
        out = static_cast<int>(l);
    }
  }
  void unsigned_param(const std::string& key, unsigned& out) {
    int i = static_cast<int>(out);
    if (const auto* v = find(key)) {
      char* end = nullptr;
      const long l = std::strtol(v->c_str(), &end, 10);
      if (v->empty() || *end != '\0' || l <= 0 || l > 4000000)
        bad(key, *v, "a positive integer");
      else
        i = static_cast<int>(l);
    }
    out = static_cast<unsigned>(i);
  }
  void string_param(const std::string& key, std::string& out) {
    if (const auto* v = find(key)) out = *v;
  }

  // Fails on the first malformed value or on a parameter nobody asked for (a typo).
  Status finish() const {
    if (!error_.empty()) return fail(Errc::invalid_argument, error_);
    for (const auto& [k, v] : spec_.params) {
      if (!seen_.count(k)) return fail(Errc::invalid_argument, spec_.text + ": unknown parameter '" + k + "'");
    }
    return {};
  }

 private:
  const std::string* find(const std::string& key) {
    seen_.insert(key);
    auto it = spec_.params.find(key);
    return it == spec_.params.end() ? nullptr : &it->second;
  }
  void bad(const std::string& key, const std::string& v, const char* expected) {
    if (error_.empty()) error_ = spec_.text + ": parameter " + key + "=" + v + " must be " + expected;
  }

  const SourceSpec& spec_;
  std::set<std::string> seen_;
  std::string error_;
};

}  // namespace mimic::devices::detail
