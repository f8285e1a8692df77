// Subcommand registry of the `mimic` program. Each cmd_<name>.cpp defines one command with
// MIMIC_COMMAND; main() dispatches by name and lists the commands in `mimic --help`. Commands
// parse their own words with cli.h (CLI11), which generates their --help.
#pragma once

#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace mimic::app {

struct Command {
  const char* name;
  const char* summary;  // one line for `mimic --help`
  int (*run)(const std::vector<std::string>& args);
};

std::vector<Command>& commands();

struct Registrar {
  explicit Registrar(Command c) { commands().push_back(c); }
};

#define MIMIC_COMMAND(ident, name, summary, fn) \
  static ::mimic::app::Registrar ident##_registrar(::mimic::app::Command{name, summary, fn})

// Prints "mimic <cmd>: <message>" and a pointer to `mimic <cmd> --help` to stderr and returns the
// usage-error exit code (2); an empty <cmd> is the program itself.
int usage_error(const char* command, const std::string& message);
// Prints "mimic <cmd>: <message>" to stderr and returns the failure exit code (1).
int failure(const char* command, const std::string& message);

// Path to ../shared/data as seen from the build, or MIMIC_SHARED_DATA when set.
std::string shared_data_dir();

}  // namespace mimic::app
