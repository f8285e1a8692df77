// `mimic sim <device>`: each virtual device registers its own subcommand with
// MIMIC_SIM_SUBCOMMAND (in apps/mimic/cmd_sim_<device>.cpp); cmd_sim.cpp dispatches by name and
// lists them in `mimic sim --help`.
#pragma once

#include <string>
#include <vector>

namespace mimic::app {

struct SimSubcommand {
  const char* name;     // "spaceball"
  const char* summary;  // one line for `mimic sim --help`
  int (*run)(const std::vector<std::string>& args);
};

std::vector<SimSubcommand>& sim_subcommands();

struct SimRegistrar {
  explicit SimRegistrar(SimSubcommand c) { sim_subcommands().push_back(c); }
};

#define MIMIC_SIM_SUBCOMMAND(ident, name, summary, fn) \
  static ::mimic::app::SimRegistrar ident##_sim_registrar(::mimic::app::SimSubcommand{name, summary, fn})

}  // namespace mimic::app
