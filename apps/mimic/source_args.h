// The `--source SPEC [--body FILE] [--calibration FILE] [--place X,Z[,DEG]] [--navigate SPEC]`
// groups of `mimic run` and `mimic view`, taken out of argv before the other options are parsed
// (those keep one value per key): the options after a --source belong to it.
#pragma once

#include <string>
#include <vector>

#include "mimic/service/scene_builder.h"

namespace mimic::app {

struct SourceArgsRules {
  // --body and --calibration before the first --source stay in argv, as defaults for every
  // source (mimic view: its --body also poses screenshots). Otherwise they, like --place and
  // --navigate there, belong to the default source (sim:walk).
  bool leading_defaults = false;
  // A --source value may list several sources separated by ';' (mimic view's older form).
  bool split_lists = false;
};

// False (and `error`) on an option without its value or given twice for one source.
bool take_sources(std::vector<std::string>& args, std::vector<service::SourceEntry>& out, std::string& error,
                  SourceArgsRules rules = {});

}  // namespace mimic::app
