// mimic sim spaceball | magellan: a virtual serial 6-DOF device on a pseudo-terminal.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "command.h"
#include "stop_signal.h"
#include "mimic/sim/virtual_magellan.h"
#include "mimic/sim/virtual_spaceball.h"
#include "sim_command.h"

namespace mimic::app {
namespace {

constexpr const char* kSpaceballUsage =
    "usage: mimic sim spaceball [--model 4000flx|3003|2003] [--seed S] [--log FILE]\n"
    "                           [--firmware X.YY] [--left-handed] [--power-up S] [--period S]\n"
    "                           [--faults P]\n"
    "\n"
    "Serves a virtual serial Spaceball on a new pseudo-terminal and prints its path as the\n"
    "first line of stdout. It speaks the real protocol (docs/devices-spaceball.md): it is a\n"
    "device already plugged in and running, so a program that opens the port is answered at\n"
    "once (with --power-up S, a cold start on every open: after S seconds it sends XON and the\n"
    "'@1 Spaceball alive and well' / '@2 Firmware version' banner, ignoring commands until\n"
    "then; @ resets it the same way after 1 s); it answers @ (reset), hm,\n"
    "\" (4000 FLX), k and %, echoes configuration commands, replies ?cmd to unknown ones, and\n"
    "sends D packets once enabled (MSS... on a 2003/3003, M on a 4000 FLX) and K / '.' packets\n"
    "when buttons change, paced at 9600 baud. The ball follows a smooth pattern set by --seed.\n"
    "Runs until Ctrl-C or SIGTERM.\n"
    "\n"
    "options:\n"
    "  --model M       4000flx (default, 12 buttons), 3003 (2 buttons + rezero) or 2003\n"
    "  --seed S        seed of the motion pattern (default 1)\n"
    "  --log FILE      write every byte in and out: '<t_s> in|out <hex>' per chunk\n"
    "  --firmware V    firmware version to report, e.g. 2.42 (default per model)\n"
    "  --left-handed   4000 FLX handedness bit and descriptor say left-handed\n"
    "  --power-up S    cold start: power up on every open of the port, banner after S\n"
    "                  seconds (the hardware takes about 2)\n"
    "  --period S      interval between D packets while the ball moves (default 0.03)\n"
    "  --faults P      probability per D packet of a line fault drawn from the seed: noise\n"
    "                  before it, a lost byte, or a corrupt ^ escape (default 0)\n"
    "\n"
    "Try: mimic sim spaceball & then mimic devices --read spaceball:<path>\n";

constexpr const char* kMagellanUsage =
    "usage: mimic sim magellan [--seed S] [--log FILE] [--period S]\n"
    "\n"
    "Serves a virtual serial Magellan / SpaceMouse on a new pseudo-terminal and prints its path\n"
    "as the first line of stdout. It answers vQ with its version line, echoes z m c n b q p\n"
    "exactly as VRPN expects, replies e1<cmd> to unknown commands, stays silent towards a\n"
    "Spaceball @RESET probe, and sends d packets (even-parity nibbles) while the puck moves\n"
    "once a mode is set (m3), and k packets when keys change; 9600 baud 8N2 pacing.\n"
    "Runs until Ctrl-C or SIGTERM.\n"
    "\n"
    "options:\n"
    "  --seed S        seed of the motion pattern (default 1)\n"
    "  --log FILE      write every byte in and out: '<t_s> in|out <hex>' per chunk\n"
    "  --period S      shortest interval between d packets (default 0.02)\n";

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

bool read_seed(Args& args, uint64_t& seed) {
  long s = 1;
  if (!args.get_int("seed", s)) return false;
  seed = static_cast<uint64_t>(s);
  return true;
}

int run_spaceball(const std::vector<std::string>& argv) {
  const char* name = "sim spaceball";
  Args args(argv, {"model", "seed", "log", "firmware", "power-up", "period", "faults"}, {"left-handed"});
  if (!args.ok()) return usage_error(name, args.error());
  if (!args.positionals().empty()) return usage_error(name, "unexpected argument '" + args.positionals()[0] + "'");
  sim::VirtualSpaceballConfig cfg;
  auto model = sim::parse_spaceball_model(args.get_or("model", "4000flx"));
  if (!model) return usage_error(name, model.error().message);
  cfg.model = *model;
  cfg.firmware = args.get_or("firmware", "");
  if (!cfg.firmware.empty() && (cfg.firmware.size() != 4 || cfg.firmware[1] != '.')) {
    return usage_error(name, "--firmware expects a version like 2.42");
  }
  cfg.right_handed = !args.has("left-handed");
  if (!read_seed(args, cfg.seed) || !args.get_double("power-up", cfg.power_up_delay_s) ||
      !args.get_double("period", cfg.data_period_s) || !args.get_double("faults", cfg.fault_rate)) {
    return usage_error(name, args.error());
  }
  if (cfg.power_up_delay_s < 0 || !(cfg.data_period_s > 0)) {
    return usage_error(name, "--power-up must be >= 0 and --period > 0");
  }
  if (cfg.fault_rate < 0 || cfg.fault_rate > 1) return usage_error(name, "--faults must be in 0..1");
  cfg.power_up_on_open = args.has("power-up");
  return serve(name, sim::start_virtual_spaceball(cfg, args.get_or("log", "")));
}

int run_magellan(const std::vector<std::string>& argv) {
  const char* name = "sim magellan";
  Args args(argv, {"seed", "log", "period"}, {});
  if (!args.ok()) return usage_error(name, args.error());
  if (!args.positionals().empty()) return usage_error(name, "unexpected argument '" + args.positionals()[0] + "'");
  sim::VirtualMagellanConfig cfg;
  if (!read_seed(args, cfg.seed) || !args.get_double("period", cfg.data_period_s)) {
    return usage_error(name, args.error());
  }
  if (!(cfg.data_period_s > 0)) return usage_error(name, "--period must be > 0");
  return serve(name, sim::start_virtual_magellan(cfg, args.get_or("log", "")));
}

}  // namespace

MIMIC_SIM_SUBCOMMAND(spaceball, "spaceball", "virtual serial Spaceball 2003/3003/4000 FLX", kSpaceballUsage,
                     run_spaceball);
MIMIC_SIM_SUBCOMMAND(magellan, "magellan", "virtual serial Magellan / SpaceMouse", kMagellanUsage, run_magellan);

}  // namespace mimic::app
