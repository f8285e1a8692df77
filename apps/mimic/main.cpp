#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "cli.h"
#include "command.h"
#include "mimic/core/text.h"

namespace mimic::app {

std::vector<Command>& commands() {
  static std::vector<Command> all;
  return all;
}

// Messages quote names, paths and peers' words: whatever they hold, they cannot drive the
// terminal (text already escaped keeps its backslashes).
int usage_error(const char* command, const std::string& message) {
  const std::string safe = terminal_safe(message, Backslash::kept);
  if (*command == '\0')
    std::fprintf(stderr, "mimic: %s\n(see 'mimic --help')\n", safe.c_str());
  else
    std::fprintf(stderr, "mimic %s: %s\n(see 'mimic %s --help')\n", command, safe.c_str(), command);
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

// `mimic`, `mimic --help`, `mimic --version`: the program's own options, and the commands listed
// from the registry (each command parses its own words).
int run_top_level(const std::vector<std::string>& args) {
  cli::Parser p("", std::string("mimic ") + MIMIC_VERSION +
                        ": puppets a realistic human avatar live from motion trackers and streams it to VR scenes.");
  p->get_formatter()->label("SUBCOMMAND", "command");
  bool version = false;
  p->add_flag("--version", version, "print the version and exit");
  auto cmds = commands();
  std::sort(cmds.begin(), cmds.end(), [](const Command& a, const Command& b) { return std::string(a.name) < b.name; });
  for (const auto& c : cmds) p->add_subcommand(c.name, c.summary)->group("commands");
  p->footer(
      "Start here: 'mimic run' serves the embedded default (simulated trackers on the built-in walk,\n"
      "the default body, 127.0.0.1:7777), 'mimic view' shows it in a window.\n"
      "Frames: metres, +Y up, the body faces +Z.");
  // Bare `mimic` says what it is and what it can do; the server is `mimic run`.
  if (args.empty() || args == std::vector<std::string>{"help"}) {
    std::fputs(p.help().c_str(), stdout);
    return 0;
  }
  if (auto exit_code = p.parse(args)) return *exit_code;
  if (version)
    std::printf("mimic %s\n", MIMIC_VERSION);
  else
    std::fputs(p.help().c_str(), stdout);
  return 0;
}

}  // namespace
}  // namespace mimic::app

int main(int argc, char** argv) {
  using namespace mimic::app;
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0].empty() || args[0][0] == '-' || args[0] == "help") return run_top_level(args);
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
  return usage_error("", "unknown command '" + name + "'");
}
