// The command line of `mimic run` (cli.h): its options with their checks, and its help.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cli.h"
#include "mimic/net/server.h"
#include "mimic/service/scene_builder.h"
#if MIMIC_HAVE_NATS
#include "mimic/net/nats.h"
#endif

namespace mimic::app {

// Everything the command line says, checked before anything is opened.
struct RunOptions {
  service::SceneSpec scene;
  net::ServerOptions server;  // --listen, --secret (or MIMIC_SECRET), --no-udp and the lean flags
  std::string publish, vmc, vrpn, nats;
  std::string http;  // --http: the browser viewer's [HOST:]PORT, HOST 127.0.0.1 when left out
  bool publishing = false, vmc_out = false, vrpn_out = false, nats_out = false;  // given on the command line
  bool http_out = false;
  double duration_s = 0;  // 0: until Ctrl-C
  long rt_priority = 0;   // 0: not SCHED_FIFO
  bool json = false, quiet = false;
#if MIMIC_HAVE_NATS
  net::NatsOptions nats_options;  // --scene, --nats-name (empty: the host name), the TTL and mesh rate
#endif
};

// Parses `mimic run`'s words into `o`: std::nullopt when the command goes on, else the exit code
// (the help or the usage error printed).
std::optional<int> parse_run_options(cli::Parser& p, const std::vector<std::string>& argv, RunOptions& o);

// What `mimic run --help` opens with.
extern const char* const kRunAbout;

}  // namespace mimic::app
