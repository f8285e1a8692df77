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

// The hand-rolled parser `mimic run` and `mimic view` still use (args.cpp); new code uses cli.h.
// Parses "--key value", "--key=value" and "--flag" options plus positionals.
class Args {
 public:
  Args(const std::vector<std::string>& argv, const std::vector<std::string>& value_options,
       const std::vector<std::string>& flag_options);

  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  bool help() const { return help_; }

  bool has(const std::string& key) const { return values_.count(key) > 0; }
  std::optional<std::string> get(const std::string& key) const;
  std::string get_or(const std::string& key, const std::string& fallback) const;
  // Numeric values: false (and an error message) when present but not a number.
  bool get_double(const std::string& key, double& out);
  bool get_int(const std::string& key, long& out);
  const std::vector<std::string>& positionals() const { return positionals_; }

 private:
  std::map<std::string, std::string> values_;
  std::vector<std::string> positionals_;
  std::string error_;
  bool help_ = false;
};

// Prints "mimic <cmd>: <message>" and a pointer to `mimic <cmd> --help` to stderr and returns the
// usage-error exit code (2); an empty <cmd> is the program itself.
int usage_error(const char* command, const std::string& message);
// Prints "mimic <cmd>: <message>" to stderr and returns the failure exit code (1).
int failure(const char* command, const std::string& message);

// Path to ../shared/data as seen from the build, or MIMIC_SHARED_DATA when set.
std::string shared_data_dir();

}  // namespace mimic::app
