// mimic sim: serves a virtual device on a pseudo-terminal; each device is a subcommand
// registered with MIMIC_SIM_SUBCOMMAND (see sim_command.h).
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "command.h"
#include "sim_command.h"

namespace mimic::app {

std::vector<SimSubcommand>& sim_subcommands() {
  static std::vector<SimSubcommand> all;
  return all;
}

namespace {

constexpr const char* kName = "sim";
constexpr const char* kUsage =
    "usage: mimic sim <device> [options]    (mimic sim <device> --help for details)\n"
    "\n"
    "Serves a virtual device on a new pseudo-terminal. The first line on stdout is the\n"
    "terminal's path; open it like a serial port with our drivers or any other program.\n"
    "Runs until Ctrl-C (SIGINT) or SIGTERM.\n";

void print_help() {
  std::printf("%s\ndevices:\n", kUsage);
  auto subs = sim_subcommands();
  std::sort(subs.begin(), subs.end(), [](const auto& a, const auto& b) { return std::string(a.name) < b.name; });
  for (const auto& s : subs) std::printf("  %-12s %s\n", s.name, s.summary);
}

int run(const std::vector<std::string>& argv) {
  if (argv.empty() || argv[0] == "--help" || argv[0] == "-h") {
    print_help();
    return argv.empty() ? 2 : 0;
  }
  for (const auto& s : sim_subcommands()) {
    if (argv[0] != s.name) continue;
    std::vector<std::string> rest(argv.begin() + 1, argv.end());
    if (std::find(rest.begin(), rest.end(), "--help") != rest.end() ||
        std::find(rest.begin(), rest.end(), "-h") != rest.end()) {
      std::printf("%s", s.usage);
      return 0;
    }
    return s.run(rest);
  }
  return usage_error(kName, "unknown device '" + argv[0] + "'");
}

}  // namespace

MIMIC_COMMAND(sim, kName, "serve a virtual device (Spaceball, Magellan ...) on a pseudo-terminal", kUsage, run);

}  // namespace mimic::app
