// mimic relay: an edge relay. Takes one scene from a NATS broker once and serves it to local
// viewers with Mimic's own protocol (the same server, handshake and limits as mimic run).
#if MIMIC_HAVE_NATS  // built with the broker transport (mimic::nats)
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <optional>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "command.h"
#include "lean_flags.h"
#include "stop_signal.h"
#include "mimic/core/process_limits.h"
#include "mimic/net/nats.h"
#include "mimic/net/server.h"

namespace mimic::app::cmd_relay {
namespace {

constexpr const char* kAbout =
    "Subscribes once to a scene on the NATS broker(s) (every publisher's models from the scene's\n"
    "key-value bucket, their pose frames from core NATS) and serves it to local viewers (mimic\n"
    "subscribe, VR scenes) exactly as mimic run serves its own avatars: same handshake, limits,\n"
    "checks, UDP option. Viewers behind different relays see the same avatars. The relay\n"
    "reconnects to the broker (or another node of its cluster) on its own. docs/scaling.md.\n"
    "An avatar is served once its publisher shows life (its heartbeat, once a second, or a\n"
    "frame) and leaves when the publisher misses 3 heartbeats (a crashed mimic run). Mesh\n"
    "viewers (mimic subscribe --mesh-lod L) get mesh frames of LOD L from the publishers that\n"
    "deform at L: the relay asks for them while such a viewer is connected.";

struct Options {
  net::ServerOptions server;
  std::string nats, scene = "default";
  double duration_s = 0;
  bool no_udp = false, json = false, quiet = false;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer("The first line on stdout is 'serving on ADDR:PORT'.");
  o.server.listen = "127.0.0.1:7778";
  p->add_option("--nats", o.nats,
                "broker address(es), nats://HOST:PORT. Credentials from MIMIC_NATS_USER\n"
                "+ MIMIC_NATS_PASSWORD, or MIMIC_NATS_TOKEN")
      ->type_name("URL[,URL]")
      ->required();
  p->add_option("--scene", o.scene, "the scene")->type_name("NAME");
  p->add_option("--listen", o.server.listen, "where viewers connect (port 0 picks one)")->type_name("ADDR:PORT");
  p->add_option("--secret", o.server.secret,
                "shared secret for publishers (prefer MIMIC_SECRET); needed on a\n"
                "non-loopback address, as for mimic run")
      ->type_name("S");
  p->add_flag("--no-udp", o.no_udp, "pose frames over TCP only");
  add_lean_flags(p.app(), o.server);
  p->add_option("--duration", o.duration_s, "stop by itself after S seconds")
      ->default_str("")
      ->check(cli::finite_range(0, INFINITY));
  p->add_flag("--json", o.json, "a JSON summary on stdout at exit (and on SIGUSR1)");
  p->add_flag("--quiet", o.quiet, "no live status line on stderr");
  return p.parse(argv);
}

volatile std::sig_atomic_t g_report = 0;
extern "C" void on_relay_report(int) { g_report = 1; }

int relay(const std::vector<std::string>& argv) {
  cli::Parser p("relay", kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  const double duration_s = o.duration_s;
  net::ServerOptions so = o.server;
  raise_descriptor_limit();  // sessions are bounded by the descriptors the process may hold
  if (so.secret.empty())
    if (const char* env = std::getenv("MIMIC_SECRET")) so.secret = env;
  so.udp = !o.no_udp;
  auto s = net::Server::create(so);
  if (!s) return failure("relay", s.error().what());
  net::Server& server = **s;

  net::NatsOptions no;
  no.servers = o.nats;
  no.scene = o.scene;
  no.name = "mimic relay " + server.endpoint();
  net::nats_credentials_from_env(no);
  auto f = net::NatsSceneFeed::create(no, server);
  if (!f) return failure("relay", f.error().what());
  std::unique_ptr<net::NatsSceneFeed> feed = std::move(*f);
  if (!feed->connected())
    std::fprintf(stderr, "mimic relay: NATS broker %s not reachable yet: serving, joining it when it comes up\n",
                 no.servers.c_str());

  clear_stop_request();
  install_stop_handler();
  std::signal(SIGUSR1, on_relay_report);
  std::printf("serving on %s\n", server.endpoint().c_str());
  std::fflush(stdout);

  using C = std::chrono::steady_clock;
  const auto start = C::now();
  auto summary = [&] {
    const auto& st = server.stats();
    const auto ns = feed->stats();
    nlohmann::json j;
    j["duration_s"] = std::chrono::duration<double>(C::now() - start).count();
    j["endpoint"] = server.endpoint();
    j["scene"] = no.scene;
    j["nats"] = {{"connected", ns.connected},
                 {"frames_in", ns.frames},
                 {"frames_dropped", ns.frames_dropped},
                 {"models", ns.models},
                 {"avatars", ns.avatars},
                 {"rejected", ns.rejected},
                 {"early_frames", ns.early_frames},
                 {"held", ns.held},
                 {"expired", ns.expired},
                 {"mesh_frames", ns.mesh_frames},
                 {"mesh_requests", ns.mesh_requests},
                 {"seq_jumps_refused", ns.seq_jumps_refused},
                 {"models_refused", ns.models_refused},
                 {"foreign", ns.foreign},
                 {"model_bytes", ns.model_bytes},
                 {"latency_ms_p50", ns.latency_ms_p50},
                 {"latency_ms_p99", ns.latency_ms_p99},
                 {"disconnects", ns.disconnects},
                 {"reconnects", ns.reconnects},
                 {"last_error", ns.last_error}};
    j["server"] = {{"subscribers", st.subscribers},         {"frames_out", st.frames_out},
                   {"frames_dropped", st.frames_dropped},   {"bytes_out", st.bytes_out},
                   {"rejected", st.rejected_total()},       {"udp_frames_out", st.udp_frames_out},
                   {"mesh_frames_out", st.mesh_frames_out}, {"sessions_accepted", st.sessions_accepted}};
    return j;
  };
  const bool status_line = !o.quiet;
  while (!stop_requested()) {
    if (duration_s > 0 && C::now() - start >= std::chrono::duration<double>(duration_s)) break;
    // The feed wakes the server as frames arrive (Server::dispatch): no polling delay here.
    server.run_until(C::now() + std::chrono::milliseconds(250));
    if (g_report) {
      g_report = 0;
      std::printf("%s\n", summary().dump().c_str());
      std::fflush(stdout);
    }
    if (status_line) {
      const auto ns = feed->stats();
      const auto& st = server.stats();
      char link[96];
      net::format_nats_state(feed->link_state(), link, sizeof link);
      std::fprintf(stderr, "\rrelay %s%s | avatars %llu | in %llu | subs %llu out %llu drop %llu rej %llu   ",
                   no.scene.c_str(), link, static_cast<unsigned long long>(ns.avatars),
                   static_cast<unsigned long long>(ns.frames), static_cast<unsigned long long>(st.subscribers),
                   static_cast<unsigned long long>(st.frames_out), static_cast<unsigned long long>(st.frames_dropped),
                   static_cast<unsigned long long>(ns.rejected + st.rejected_total()));
      std::fflush(stderr);
    }
  }
  std::signal(SIGUSR1, SIG_DFL);
  if (status_line) std::fputs("\n", stderr);
  if (o.json) std::printf("%s\n", summary().dump().c_str());
  feed.reset();  // before the server it feeds
  return 0;
}

}  // namespace

MIMIC_COMMAND(relay, "relay", "serve a scene from a NATS broker to local viewers (an edge relay)", relay);

}  // namespace mimic::app::cmd_relay
#endif  // MIMIC_HAVE_NATS
