// Every command answers --help and -h with its usage (exit 0), an unknown option with a usage
// error (exit 2), and a value outside its declared range with a usage error naming the option.
// The commands are the ones `mimic --help` lists (and the devices `mimic sim --help` lists), so a
// new command is checked without being added here.
#include <gtest/gtest.h>

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include "run_mimic.h"

namespace help_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

// The names listed under `heading:` in a help text ("  export   write a rigged ...").
std::vector<std::string> listed(const std::string& help, const std::string& heading) {
  std::vector<std::string> names;
  std::istringstream in(help);
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line == heading + ":") {
      inside = true;
      continue;
    }
    if (!inside) continue;
    if (line.size() < 3 || line.compare(0, 2, "  ") != 0 || line[2] == ' ') break;
    names.push_back(line.substr(2, line.find(' ', 2) - 2));
  }
  return names;
}

// "mimic export" and the like, "sim flock" for each device of `mimic sim`.
std::vector<std::string> every_command() {
  const Outcome top = run_mimic("--help");
  EXPECT_EQ(top.status, 0) << top.output;
  std::vector<std::string> all = listed(top.output, "commands");
  const Outcome sim = run_mimic("sim --help");
  for (const std::string& device : listed(sim.output, "devices")) all.push_back("sim " + device);
  return all;
}

// Option lines of a usage: "  --lod INT in [0 - 3] ..." (the help option aside).
int option_lines(const std::string& help) {
  int n = 0;
  std::istringstream in(help);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("  --", 0) == 0) ++n;
  return n;
}

TEST(CliHelp, EveryCommandIsListed) {
  const std::vector<std::string> all = every_command();
  for (const char* expected : {"bench",   "calibrate", "compare",   "devices", "eval-solver", "export",       "inspect",
                               "measure", "mesh",      "record",    "relay",   "replay",      "retarget",     "run",
                               "scale",   "sim",       "subscribe", "view",    "sim flock",   "sim spaceball"})
    EXPECT_NE(std::find(all.begin(), all.end(), expected), all.end()) << expected;
}

TEST(CliHelp, EveryCommandAnswersHelpAndH) {
  for (const std::string& command : every_command()) {
    for (const char* flag : {"--help", "-h"}) {
      const Outcome r = run_mimic(command + " " + flag);
      EXPECT_EQ(r.status, 0) << "mimic " << command << " " << flag << "\n" << r.output;
      EXPECT_NE(r.output.find("usage: mimic " + command), std::string::npos)
          << "mimic " << command << " " << flag << "\n"
          << r.output;
      // Its options (or, for `mimic sim`, its devices) are listed.
      const bool lists_devices = command == "sim" && r.output.find("devices:") != std::string::npos;
      EXPECT_TRUE(lists_devices || option_lines(r.output) >= 2) << "mimic " << command << " " << flag << "\n"
                                                                << r.output;
      EXPECT_EQ(r.output.find("(see 'mimic"), std::string::npos) << "mimic " << command << " " << flag << "\n"
                                                                 << r.output;
    }
  }
}

TEST(CliHelp, AnUnknownOptionIsAUsageError) {
  for (const std::string& command : every_command()) {
    const Outcome r = run_mimic(command + " --no-such-option");
    EXPECT_EQ(r.status, 2) << "mimic " << command << "\n" << r.output;
    EXPECT_NE(r.output.find("--no-such-option"), std::string::npos) << "mimic " << command << "\n" << r.output;
    EXPECT_NE(r.output.find("--help"), std::string::npos) << "mimic " << command << "\n" << r.output;
  }
  EXPECT_EQ(run_mimic("--no-such-option").status, 2);
}

TEST(CliHelp, AValueOutsideItsRangeIsAUsageError) {
  // One declared range per command that has one; each names the option at fault.
  // The other options are good: the bad value alone makes the error.
  const std::string out = " --out /nonexistent-mimic-dir/x";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"bench --section net --realtime 100", "--realtime"},
      {"calibrate --source sim:idle" + out + " --seconds 61", "--seconds"},
      {"compare --tolerance 1", "--tolerance"},
      {"devices --watch --interval 0", "--interval"},
      {"eval-solver --bvh x.bvh --dropout 2", "--dropout"},
      {"export --motion walk" + out + " --lod 9", "--lod"},
      {"export --motion walk" + out + " --fps nan", "--fps"},
      {"export --motion dance" + out, "--motion"},
      {"inspect --lod 4", "--lod"},
      {"measure --units-per-metre 0", "--units-per-metre"},
      {"mesh --pose zero --method full --subdivision 17" + out, "--subdivision"},
      {"record --source sim:walk" + out + " --duration -1", "--duration"},
      {"relay --nats nats://127.0.0.1:1 --lean-shift 9", "--lean-shift"},
      {"replay x.mlog --speed -1", "--speed"},
      {"retarget --bvh x.bvh" + out + " --scale 0", "--scale"},
      {"scale --frontal 11", "--frontal"},
      {"sim flock --birds 15", "--birds"},
      {"sim spaceball --faults 2", "--faults"},
      {"sim magellan --period 0", "--period"},
      {"subscribe --mesh-lod 8", "--mesh-lod"},
  };
  const std::vector<std::string> all = every_command();
  for (const auto& [args, option] : cases) {
    // A command this build leaves out (no NATS, no window) is not checked.
    const std::string command =
        args.rfind("sim ", 0) == 0 ? args.substr(0, args.find(' ', 4)) : args.substr(0, args.find(' '));
    if (std::find(all.begin(), all.end(), command) == all.end()) continue;
    const Outcome r = run_mimic(args);
    EXPECT_EQ(r.status, 2) << "mimic " << args << "\n" << r.output;
    EXPECT_NE(r.output.find(option), std::string::npos) << "mimic " << args << "\n" << r.output;
  }
}

}  // namespace

}  // namespace help_test
