// The old hand-rolled parser, kept only for `mimic run` and `mimic view` until they move to cli.h.
#include <algorithm>
#include <cstdlib>

#include "command.h"

namespace mimic::app {

Args::Args(const std::vector<std::string>& argv, const std::vector<std::string>& value_options,
           const std::vector<std::string>& flag_options) {
  auto is = [](const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  };
  for (size_t i = 0; i < argv.size(); ++i) {
    std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      help_ = true;
      continue;
    }
    if (a.size() > 2 && a.rfind("--", 0) == 0) {
      std::string key = a.substr(2), value;
      bool inline_value = false;
      if (auto eq = key.find('='); eq != std::string::npos) {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
        inline_value = true;
      }
      if (is(flag_options, key)) {
        if (inline_value) {
          error_ = "option --" + key + " takes no value";
          return;
        }
        values_[key] = "1";
      } else if (is(value_options, key)) {
        if (!inline_value) {
          if (i + 1 >= argv.size()) {
            error_ = "option --" + key + " needs a value";
            return;
          }
          value = argv[++i];
        }
        values_[key] = value;
      } else {
        error_ = "unknown option --" + key;
        return;
      }
    } else {
      positionals_.push_back(a);
    }
  }
}

std::optional<std::string> Args::get(const std::string& key) const {
  auto it = values_.find(key);
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

std::string Args::get_or(const std::string& key, const std::string& fallback) const {
  auto v = get(key);
  return v ? *v : fallback;
}

bool Args::get_double(const std::string& key, double& out) {
  auto v = get(key);
  if (!v) return true;
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0') {
    error_ = "--" + key + " expects a number, got '" + *v + "'";
    return false;
  }
  out = d;
  return true;
}

bool Args::get_int(const std::string& key, long& out) {
  auto v = get(key);
  if (!v) return true;
  char* end = nullptr;
  const long d = std::strtol(v->c_str(), &end, 10);
  if (v->empty() || *end != '\0') {
    error_ = "--" + key + " expects an integer, got '" + *v + "'";
    return false;
  }
  out = d;
  return true;
}

}  // namespace mimic::app
