#include "source_args.h"

namespace mimic::app {
namespace {

constexpr const char* kGroupOptions[] = {"--source", "--body", "--calibration", "--place", "--navigate"};

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

bool take_sources(std::vector<std::string>& args, std::vector<service::SourceEntry>& out, std::string& error,
                  SourceArgsRules rules) {
  std::vector<std::string> rest;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string a = args[i];
    std::string key, value;
    for (const char* k : kGroupOptions) {
      if (a == k) {
        if (i + 1 >= args.size()) {
          error = std::string("option ") + k + " needs a value";
          return false;
        }
        key = k;
        value = args[++i];
      } else if (a.rfind(std::string(k) + "=", 0) == 0) {
        key = k;
        value = a.substr(std::string(k).size() + 1);
      }
    }
    const bool leading_default = out.empty() && rules.leading_defaults && (key == "--body" || key == "--calibration");
    if (key.empty() || leading_default) {
      if (leading_default)
        rest.push_back(key), rest.push_back(value);
      else
        rest.push_back(a);
      continue;
    }
    if (key == "--source") {
      for (const std::string& spec : rules.split_lists ? split_list(value) : std::vector<std::string>{value}) {
        out.emplace_back();
        out.back().spec = spec;
      }
      if (out.empty()) {
        error = "--source needs a source spec";
        return false;
      }
      continue;
    }
    if (out.empty()) out.emplace_back();
    service::SourceEntry& e = out.back();
    std::string& slot = key == "--body"          ? e.body
                        : key == "--calibration" ? e.calibration
                        : key == "--place"       ? e.place
                                                 : e.navigate;
    if (!slot.empty()) {
      error = "two " + key + " options for one --source";
      return false;
    }
    slot = value;
  }
  args = rest;
  return true;
}

}  // namespace mimic::app
