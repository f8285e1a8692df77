// The `--source SPEC [--body FILE] [--calibration FILE] [--place X,Z[,DEG]] [--navigate SPEC]`
// groups of `mimic run` and `mimic view` (cli::OptionGroups): the options after a --source
// belong to it; one before any --source opens the default source (sim:walk).
#pragma once

#include <string>
#include <vector>

#include "cli.h"
#include "mimic/service/scene_builder.h"

namespace mimic::app {

struct SourceArgsRules {
  // --body and --calibration before the first --source are defaults for every source (mimic
  // view: its --body also poses screenshots); the group they open is a source of its own only
  // when it also has --place or --navigate. Otherwise that group is the default source.
  bool leading_defaults = false;
  // A --source value may list several sources separated by ';' (mimic view's older form); the
  // members after it belong to the last.
  bool split_lists = false;
};

// The scene's sources from the groups of "--source" with the members body, calibration, place
// and navigate. With leading_defaults, `defaults` gets the leading --body and --calibration (and
// every source without its own takes them). "" when good, else the usage error.
std::string sources_from_groups(const std::vector<cli::OptionGroups::Group>& groups, SourceArgsRules rules,
                                std::vector<service::SourceEntry>& out, service::SourceEntry& defaults);

}  // namespace mimic::app
