// mimic sim spaceball | magellan: a virtual serial 6-DOF device on a pseudo-terminal.
#include <atomic>
#include <cmath>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "cli.h"
#include "command.h"
#include "stop_signal.h"
#include "mimic/sim/virtual_magellan.h"
#include "mimic/sim/virtual_spaceball.h"
#include "sim_command.h"

namespace mimic::app::cmd_sim_spaceball {
namespace {

constexpr const char* kSpaceballAbout =
    "Serves a virtual serial Spaceball on a new pseudo-terminal and prints its path as the\n"
    "first line of stdout. It speaks the real protocol (docs/devices-spaceball.md): it is a\n"
    "device already plugged in and running, so a program that opens the port is answered at\n"
    "once (with --power-up S, a cold start on every open: after S seconds it sends XON and the\n"
    "'@1 Spaceball alive and well' / '@2 Firmware version' banner, ignoring commands until\n"
    "then; @ resets it the same way after 1 s); it answers @ (reset), hm,\n"
    "\" (4000 FLX), k and %, echoes configuration commands, replies ?cmd to unknown ones, and\n"
    "sends D packets once enabled (MSS... on a 2003/3003, M on a 4000 FLX) and K / '.' packets\n"
    "when buttons change, paced at 9600 baud. The ball follows a smooth pattern set by --seed.\n"
    "Runs until Ctrl-C or SIGTERM.";

constexpr const char* kMagellanAbout =
    "Serves a virtual serial Magellan / SpaceMouse on a new pseudo-terminal and prints its path\n"
    "as the first line of stdout. It answers vQ with its version line, echoes z m c n b q p\n"
    "exactly as VRPN expects, replies e1<cmd> to unknown commands, stays silent towards a\n"
    "Spaceball @RESET probe, and sends d packets (even-parity nibbles) while the puck moves\n"
    "once a mode is set (m3), and k packets when keys change; 9600 baud 8N2 pacing.\n"
    "Runs until Ctrl-C or SIGTERM.";

// --seed, --log and --period, which both devices take.
struct Common {
  uint64_t seed = 1;
  std::string log;
};

void add_common(CLI::App& app, Common& c, double& period_s, const char* packets) {
  app.add_option("--seed", c.seed, "seed of the motion pattern");
  app.add_option("--log", c.log, "write every byte in and out: '<t_s> in|out <hex>' per chunk")->type_name("FILE");
  app.add_option("--period", period_s, std::string("interval between ") + packets + " packets while the device moves")
      ->check(cli::finite_range(0, INFINITY, cli::Bound::exclusive));
}

int serve(const char* name, Result<std::unique_ptr<sim::PtyServer>> server) {
  if (!server) return failure(name, server.error().what());
  install_stop_handler();
  std::printf("%s\n", (*server)->path().c_str());
  std::fflush(stdout);
  std::fprintf(stderr, "mimic sim %s: serving on %s (Ctrl-C to stop)\n", name + 4, (*server)->path().c_str());
  while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const auto st = (*server)->stats();
  (*server)->stop();
  std::fprintf(stderr,
               "mimic sim %s: stopped; %llu bytes in, %llu bytes out, port opened %llu times, %llu line-setting "
               "mismatches\n",
               name + 4, static_cast<unsigned long long>(st.bytes_in), static_cast<unsigned long long>(st.bytes_out),
               static_cast<unsigned long long>(st.host_opens), static_cast<unsigned long long>(st.line_mismatches));
  return 0;
}

int run_spaceball(const std::vector<std::string>& argv) {
  cli::Parser p("sim spaceball", kSpaceballAbout);
  p->footer("Try: mimic sim spaceball & then mimic devices --read spaceball:<path>");
  sim::VirtualSpaceballConfig cfg;
  Common common;
  std::string model = "4000flx";
  bool left_handed = false;
  p->add_option("--model", model, "4000flx (12 buttons), 3003 (2 buttons + rezero) or 2003")
      ->check(cli::parsed_by(sim::parse_spaceball_model, "4000flx|3003|2003"));
  add_common(p.app(), common, cfg.data_period_s, "D");
  p->add_option("--firmware", cfg.firmware, "firmware version to report, e.g. 2.42 (default per model)")
      ->type_name("X.YY")
      ->check(CLI::Validator(
          [](std::string& v) { return v.size() == 4 && v[1] == '.' ? "" : "expects a version like 2.42"; }, ""));
  p->add_flag("--left-handed", left_handed, "4000 FLX handedness bit and descriptor say left-handed");
  auto* power_up = p->add_option("--power-up", cfg.power_up_delay_s,
                                 "cold start: power up on every open of the port, banner after S\n"
                                 "seconds (the hardware takes about 2)")
                       ->check(cli::finite_range(0, INFINITY));
  p->add_option("--faults", cfg.fault_rate,
                "probability per D packet of a line fault drawn from the seed: noise\n"
                "before it, a lost byte, or a corrupt ^ escape")
      ->check(cli::finite_range(0, 1));
  if (auto exit_code = p.parse(argv)) return *exit_code;
  cfg.model = *sim::parse_spaceball_model(model);
  cfg.seed = common.seed;
  cfg.right_handed = !left_handed;
  cfg.power_up_on_open = power_up->count() > 0;
  return serve("sim spaceball", sim::start_virtual_spaceball(cfg, common.log));
}

int run_magellan(const std::vector<std::string>& argv) {
  cli::Parser p("sim magellan", kMagellanAbout);
  sim::VirtualMagellanConfig cfg;
  Common common;
  add_common(p.app(), common, cfg.data_period_s, "d");
  if (auto exit_code = p.parse(argv)) return *exit_code;
  cfg.seed = common.seed;
  return serve("sim magellan", sim::start_virtual_magellan(cfg, common.log));
}

}  // namespace

MIMIC_SIM_SUBCOMMAND(spaceball, "spaceball", "virtual serial Spaceball 2003/3003/4000 FLX", run_spaceball);
MIMIC_SIM_SUBCOMMAND(magellan, "magellan", "virtual serial Magellan / SpaceMouse", run_magellan);

}  // namespace mimic::app::cmd_sim_spaceball
