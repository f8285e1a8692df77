#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "command.h"
#include "mimic/core/text.h"

namespace mimic::app {

std::vector<Command>& commands() {
  static std::vector<Command> all;
  return all;
}

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

// Messages quote names, paths and peers' words: whatever they hold, they cannot drive the
// terminal (text already escaped keeps its backslashes).
int usage_error(const char* command, const std::string& message) {
  std::fprintf(stderr, "mimic %s: %s\n(see 'mimic %s --help')\n", command,
               terminal_safe(message, Backslash::kept).c_str(), command);
  return 2;
}

int failure(const char* command, const std::string& message) {
  std::fprintf(stderr, "mimic %s: %s\n", command, terminal_safe(message, Backslash::kept).c_str());
  return 1;
}

std::string shared_data_dir() {
  if (const char* env = std::getenv("MIMIC_SHARED_DATA")) return env;
  return MIMIC_DEFAULT_SHARED_DATA;
}

namespace {

void print_help() {
  std::printf(
      "mimic %s: puppets a realistic human avatar live from motion trackers and streams it to VR "
      "scenes.\n\nusage: mimic <command> [options]    (mimic <command> --help for details)\n\ncommands:\n",
      MIMIC_VERSION);
  auto cmds = commands();
  std::sort(cmds.begin(), cmds.end(), [](const Command& a, const Command& b) {
    return std::string(a.name) < b.name;
  });
  for (const auto& c : cmds) std::printf("  %-14s %s\n", c.name, c.summary);
  std::printf("\nStart here: 'mimic run' serves the embedded default (simulated trackers on the built-in "
              "walk,\nthe default body, 127.0.0.1:7777), 'mimic view' shows it in a window.\n"
              "Frames: metres, +Y up, the body faces +Z.\n");
}

}  // namespace
}  // namespace mimic::app

int main(int argc, char** argv) {
  using namespace mimic::app;
  std::vector<std::string> args(argv + 1, argv + argc);
  // Bare `mimic` says what it is and what it can do; the server is `mimic run`.
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    print_help();
    return 0;
  }
  if (!args.empty() && args[0] == "--version") {
    std::printf("mimic %s\n", MIMIC_VERSION);
    return 0;
  }
  std::string name = args[0];
  args.erase(args.begin());
  for (const auto& c : commands()) {
    if (name != c.name) continue;
    try {
      return c.run(args);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "mimic %s: %s\n", c.name, e.what());
      return 1;
    }
  }
  std::fprintf(stderr, "mimic: unknown command '%s' (see 'mimic --help')\n", name.c_str());
  return 2;
}
