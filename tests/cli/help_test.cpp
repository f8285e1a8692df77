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

#ifndef MIMIC_HAVE_NATS
#define MIMIC_HAVE_NATS 0
#endif

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
  for (const char* expected :
       {"bench",   "calibrate", "compare", "devices",   "eval-solver", "export",    "fit",
        "inspect", "measure",   "mesh",    "record",    "relay",       "replay",    "retarget",
        "run",     "scale",     "sim",     "subscribe", "view",        "sim flock", "sim spaceball"})
    if (MIMIC_HAVE_NATS || std::string(expected) != "relay") {  // the relay takes its scene from a broker
      EXPECT_NE(std::find(all.begin(), all.end(), expected), all.end()) << expected;
    }
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
      {"intersect --motion walk --every 0", "--every"},
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
      {"run --listen 127.0.0.1:0 --duration 1 --mesh-lod 4", "--mesh-lod"},
      {"view --screenshot x.png --ray-ring -5", "--ray-ring"},
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

// mimic run and mimic view: every option they take is listed in their generated help (the
// sources' forms, the exit codes too), and a wrong use is a usage error that says what is wrong.
TEST(CliHelp, RunListsItsOptionsAndRefusesWrongUses) {
  const Outcome help = run_mimic("run --help");
  ASSERT_EQ(help.status, 0) << help.output;
  for (const char* expected : {"--source SPEC",
                               "--body FILE",
                               "--place X,Z[,DEG]",
                               "--navigate SPEC",
                               "--calibration FILE",
                               "--room WxD",
                               "--listen ADDR:PORT",
                               "--no-udp",
                               "--lean-shift",
                               "--lean-key-interval",
                               "--secret S",
                               "--publish HOST:PORT",
                               "--vmc HOST:PORT",
                               "--vrpn [HOST:]PORT",
                               "--mesh-lod INT in [0 - 3]",
                               "--mesh-method",
                               "--duration",
                               "--realtime",
                               "--json",
                               "--quiet",
                               "flock:/dev/ttyUSB0?birds=4",
                               "vrpn:Tracker0@host",
                               "replay:",
                               "actor:wander",
                               "exit status:",
                               "serving on ADDR:PORT"})
    EXPECT_NE(help.output.find(expected), std::string::npos) << expected << " in\n" << help.output;
  const bool nats = help.output.find("--nats URL") != std::string::npos;
  if (nats) {
    for (const char* expected : {"--scene NAME", "--nats-name", "--nats-model-ttl", "--nats-mesh-hz", "(needs --nats)"})
      EXPECT_NE(help.output.find(expected), std::string::npos) << expected << " in\n" << help.output;
  }

  struct Case {
    std::string args;
    std::vector<std::string> says;
  };
  std::vector<Case> cases = {
      {"--mesh-lod 4", {"--mesh-lod", "0 to 3"}},
      {"--realtime 100", {"--realtime"}},
      {"--room 1x1", {"--room", "WxD"}},
      {"--mesh-method raytrace", {"--mesh-method"}},
      {"--duration nan", {"--duration"}},
      {"--lean-shift 2 --publish 127.0.0.1:1", {"--lean-shift", "--publish"}},
      {"--source sim:walk --body a.json --body b.json", {"two --body options for one --source"}},
      // Before any --source a member opens the default source: once, like any other.
      {"--place 1,0 --place 2,0 --source sim:idle", {"two --place options for one --source"}},
      {"--no-such-option", {"unknown option --no-such-option"}},
      {"stray", {"unexpected argument 'stray'"}},
      {"--source", {"--source needs a value"}},
  };
  if (nats) {
    cases.push_back({"--nats nats://127.0.0.1:1 --publish 127.0.0.1:1", {"--nats", "--publish", "excludes"}});
    cases.push_back({"--scene stage", {"--scene requires --nats"}});
    cases.push_back({"--nats nats://127.0.0.1:1 --nats-mesh-hz 500", {"--nats-mesh-hz"}});
    cases.push_back({"--nats nats://127.0.0.1:1 --nats-model-ttl 1", {"--nats-model-ttl", "3 to 86400"}});
  }
  for (const Case& c : cases) {
    const Outcome r = run_mimic("run --listen 127.0.0.1:0 --quiet --duration 1 " + c.args);
    EXPECT_EQ(r.status, 2) << "mimic run " << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("mimic run: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("(see 'mimic run --help')"), std::string::npos) << r.output;
    for (const std::string& s : c.says) EXPECT_NE(r.output.find(s), std::string::npos) << s << " in\n" << r.output;
  }
}

TEST(CliHelp, ViewListsItsOptionsAndRefusesWrongUses) {
  const std::vector<std::string> all = every_command();
  if (std::find(all.begin(), all.end(), "view") == all.end()) GTEST_SKIP() << "built without the viewer";
  const Outcome help = run_mimic("view --help");
  ASSERT_EQ(help.status, 0) << help.output;
  for (const char* expected : {"--screenshot OUT.png",
                               "--bvh CLIP",
                               "--frame",
                               "--motion",
                               "--time",
                               "--pose",
                               "--set",
                               "--empty",
                               "--source SPEC",
                               "--body FILE",
                               "--calibration FILE",
                               "--place X,Z[,DEG]",
                               "--navigate SPEC",
                               "--room WxD",
                               "--connect HOST:PORT",
                               "--no-lean",
                               "--camera",
                               "--size WxH",
                               "--lod",
                               "--overlay",
                               "--ray-ring",
                               "--see-through",
                               "--method",
                               "--frame-height",
                               "--no-grid",
                               "--frames",
                               "--capture",
                               "--no-vsync",
                               "--help-overlay",
                               "--no-panel",
                               "--eyes",
                               "interactive keys:",
                               "exit status:"})
    EXPECT_NE(help.output.find(expected), std::string::npos) << expected << " in\n" << help.output;
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"--screenshot x.png --lod 4", {"--lod"}},
      {"--screenshot x.png --size 8x8", {"--size", "WxH"}},
      {"--screenshot x.png --camera above", {"--camera", "front, back, left, right, side, three-quarter or top"}},
      {"--screenshot x.png --overlay bones", {"--overlay"}},
      {"--screenshot x.png --frame-height 30", {"--frame-height"}},
      {"--screenshot x.png --motion walk --bvh x.bvh", {"--bvh", "--motion"}},
      {"--screenshot x.png --source sim:walk", {"--screenshot", "--source"}},
      {"--screenshot x.png --place 1,0", {"--screenshot draws a posed body"}},
      {"--source sim:walk --connect 127.0.0.1:1", {"--connect", "--source"}},
      {"--source ';' --frames 1", {"--source needs a source spec"}},
      {"--source sim:walk --place 1,0 --place 2,0 --frames 1", {"two --place options for one --source"}},
      {"--frames -1", {"--frames"}},
      {"--no-such-option", {"unknown option --no-such-option"}},
  };
  for (const auto& [args, says] : cases) {
    const Outcome r = run_mimic("view " + args);
    EXPECT_EQ(r.status, 2) << "mimic view " << args << "\n" << r.output;
    EXPECT_NE(r.output.find("(see 'mimic view --help')"), std::string::npos) << r.output;
    for (const std::string& s : says) EXPECT_NE(r.output.find(s), std::string::npos) << s << " in\n" << r.output;
  }
}

}  // namespace

}  // namespace help_test
