#include "source_args.h"

namespace mimic::app {
namespace {

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= list.size()) {
    size_t semi = list.find(';', start);
    if (semi == std::string::npos) semi = list.size();
    if (semi > start) out.push_back(list.substr(start, semi - start));
    start = semi + 1;
  }
  return out;
}

}  // namespace

std::string sources_from_groups(const std::vector<cli::OptionGroups::Group>& groups, SourceArgsRules rules,
                                std::vector<service::SourceEntry>& out, service::SourceEntry& defaults) {
  for (const cli::OptionGroups::Group& g : groups) {
    service::SourceEntry entry;
    entry.body = g.get("body");
    entry.calibration = g.get("calibration");
    entry.place = g.get("place");
    entry.navigate = g.get("navigate");
    if (g.implicit && rules.leading_defaults) {
      defaults.body = entry.body;
      defaults.calibration = entry.calibration;
      if (entry.place.empty() && entry.navigate.empty()) continue;
    }
    const std::vector<std::string> specs = rules.split_lists ? split_list(g.head) : std::vector<std::string>{g.head};
    if (specs.empty()) return "--source needs a source spec";
    for (size_t i = 0; i + 1 < specs.size(); ++i) {
      out.emplace_back();
      out.back().spec = specs[i];
    }
    entry.spec = specs.back();
    out.push_back(std::move(entry));
  }
  for (service::SourceEntry& e : out) {
    if (e.body.empty()) e.body = defaults.body;
    if (e.calibration.empty()) e.calibration = defaults.calibration;
  }
  return {};
}

}  // namespace mimic::app
