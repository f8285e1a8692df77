// mimic sim: serves a virtual device on a pseudo-terminal; each device is a subcommand
// registered with MIMIC_SIM_SUBCOMMAND (see sim_command.h) that parses its own words.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "cli.h"
#include "command.h"
#include "sim_command.h"

namespace mimic::app {

std::vector<SimSubcommand>& sim_subcommands() {
  static std::vector<SimSubcommand> all;
  return all;
}

}  // namespace mimic::app

namespace mimic::app::cmd_sim {

namespace {

constexpr const char* kName = "sim";

int run(const std::vector<std::string>& argv) {
  for (const auto& s : sim_subcommands())
    if (!argv.empty() && argv[0] == s.name) return s.run({argv.begin() + 1, argv.end()});
  cli::Parser p(kName,
                "Serves a virtual device on a new pseudo-terminal. The first line on stdout is the\n"
                "terminal's path; open it like a serial port with our drivers or any other program.\n"
                "Runs until Ctrl-C (SIGINT) or SIGTERM.");
  p->get_formatter()->label("SUBCOMMAND", "device");
  auto subs = sim_subcommands();
  std::sort(subs.begin(), subs.end(), [](const auto& a, const auto& b) { return std::string(a.name) < b.name; });
  for (const auto& s : subs) p->add_subcommand(s.name, s.summary)->group("devices");
  if (argv.empty()) {
    std::fputs(p.help().c_str(), stdout);
    return 2;  // a device is required
  }
  if (argv[0].rfind('-', 0) != 0) return p.usage_error("unknown device '" + argv[0] + "'");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  return p.usage_error("name a device");
}

}  // namespace

MIMIC_COMMAND(sim, kName, "serve a virtual device (Spaceball, Magellan ...) on a pseudo-terminal", run);

}  // namespace mimic::app::cmd_sim
