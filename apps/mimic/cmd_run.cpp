// mimic run: the realtime service. Reads trackers, solves, deforms, and serves the avatars.
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "command.h"
#include "status_line.h"
#include "stop_signal.h"
#include <unistd.h>

#include "mimic/core/process_limits.h"
#include "mimic/core/thread_priority.h"
#include "mimic/net/client.h"
#if MIMIC_HAVE_NATS  // built with the broker transport (mimic::nats); else --nats is refused
#include "mimic/net/nats.h"
#else
namespace mimic::net {
class NatsPublisher {};  // absent: run refuses --nats
}  // namespace mimic::net
#endif
#include "mimic/net/server.h"
#include "mimic/net/vmc.h"
#include "mimic/net/vrpn_server.h"
#include "mimic/net/web_server.h"
#include "mimic/core/alloc_counter.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/scene.h"
#include "mimic/service/scene_builder.h"
#include "run_options.h"

namespace mimic::app::cmd_run {
using namespace ::mimic::service;
namespace {

constexpr int kLoopNice = -10;
// Trackers stream at 100 Hz and more: a loop pass that starts more than this after the one
// before let at least one frame period go by unserved (a missed tick).
constexpr std::chrono::milliseconds kTickPeriod{10};

std::atomic<bool> g_report{false};
extern "C" void on_report_signal(int) { g_report = true; }

// The live status line, most useful first: the frame rate (per avatar) and a silent source
// always show; then end-to-end latency, missed ticks and the broker; then the subscribers; the
// per-stage timings go first when the terminal is narrow (docs/status-line.md).
void write_status(StatusLine& line, Pipeline& pipeline, net::Server* server, net::NatsPublisher* nats, double fps,
                  uint64_t missed_ticks, double longest_gap_ms) {
  line.begin(StatusLine::Clock::now());
  const size_t n = pipeline.avatar_count();
  if (n == 1)
    line.add(0, "1 avatar %5.1f fps", fps);
  else
    line.add(0, "%zu avatars %5.1f fps each", n, fps);
  if (pipeline.silent_sources() > 0) line.add(0, "%zu source(s) SILENT: sending stale", pipeline.silent_sources());
  // A source not (or no longer) connected says so, with why: a VRPN server that does not answer,
  // a device that went away.
  for (size_t i = 0; i < n; ++i) {
    const devices::DeviceStatus st = pipeline.feed(i).status();
    if (st.state != devices::DeviceState::connecting && st.state != devices::DeviceState::disconnected &&
        st.state != devices::DeviceState::error)
      continue;
    const char* state = st.state == devices::DeviceState::connecting ? "connecting"
                        : st.state == devices::DeviceState::error    ? "ERROR"
                                                                     : "disconnected";
    if (st.last_error.empty())
      line.add(0, "source %zu %s", i, state);
    else
      line.add(0, "source %zu %s: %.60s", i, state, st.last_error.c_str());
  }
  const auto latency = pipeline.timer(kStageLatency).summary();
  line.add(1, "latency %.1f/%.1f ms", latency.p50_us * 1e-3, latency.p99_us * 1e-3);
  if (missed_ticks > 0)
    line.add(2, "missed %llu ticks (max gap %.0f ms)", static_cast<unsigned long long>(missed_ticks), longest_gap_ms);
#if MIMIC_HAVE_NATS
  if (nats) {
    char text[96];
    const auto link = nats->link_state();
    net::format_nats_state(link, text, sizeof text);
    // format_nats_state writes " | nats ...": the line puts its own separators.
    const char* t = text;
    while (*t == ' ' || *t == '|') ++t;
    line.add(2, "%s%s", t, link.connected ? "" : ": local only");
  }
#else
  (void)nats;
#endif
  if (server) {
    const auto& st = server->stats();
    line.add(3, "subs %llu drop %llu rej %llu", static_cast<unsigned long long>(st.subscribers),
             static_cast<unsigned long long>(st.frames_dropped), static_cast<unsigned long long>(st.rejected_total()));
  }
  char stages[112];
  int at = std::snprintf(stages, sizeof stages, "p50/p99 us");
  for (int s = 0; s < kStageLatency && at < int(sizeof stages); ++s) {
    const auto sum = pipeline.timer(s).summary();
    at +=
        std::snprintf(stages + at, sizeof stages - size_t(at), " %s %.0f/%.0f", stage_name(s), sum.p50_us, sum.p99_us);
  }
  line.add(5, "%s", stages);
  line.emit();
}

// The network outputs, each also a pose sink of the pipeline.
struct Outputs {
  std::unique_ptr<net::Server> server;
  std::unique_ptr<net::Client> publisher;
  std::unique_ptr<net::NatsPublisher> nats;
  std::unique_ptr<net::VmcSender> vmc;
  std::unique_ptr<net::VrpnServer> vrpn;
  std::unique_ptr<net::WebServer> web;  // the browser viewer, a subscriber of `server`
  std::string where;                    // the first line on stdout

  // The scene server first: it numbers the avatars for every sink (service/sink.h).
  SinkList sinks() const {
    SinkList out;
    if (server) out.push_back(make_server_sink(*server));
    if (publisher) out.push_back(make_publisher_sink(*publisher));
    if (vmc) out.push_back(make_vmc_sink(*vmc));
    if (vrpn) out.push_back(make_vrpn_sink(*vrpn));
#if MIMIC_HAVE_NATS
    if (nats) out.push_back(make_nats_sink(*nats));
#endif
    return out;
  }
};

// Host the scene here (--listen) or publish into a remote one (--publish); -1 when done.
int open_scene_output(const RunOptions& o, Outputs& out) {
  if (o.publishing) {
    net::ClientOptions co;
    co.connect = o.publish;
    co.role = net::Role::publisher;
    co.secret = o.server.secret;
    co.name = "mimic run";
    auto c = net::Client::connect(co);
    if (!c) return failure("run", c.error().what());
    out.publisher = std::move(*c);
    out.where = "publishing into " + co.connect;
    return -1;
  }
  net::ServerOptions so = o.server;
  // Sessions are bounded by the descriptors the process may hold: as many as the system allows.
  raise_descriptor_limit();
  // Mesh frames are deformed at one LOD: a subscriber asking for another is told so.
  so.mesh_lods_served = static_cast<uint8_t>(1u << o.scene.mesh_lod);
  auto s = net::Server::create(so);
  if (!s) return failure("run", s.error().what());
  out.server = std::move(*s);
  out.where = "serving on " + out.server->endpoint();
  if (o.http_out) {
    net::WebServerOptions wo;
    wo.listen = o.http;
    wo.scene = out.server->endpoint();
    wo.root = net::default_web_root("/proc/self/exe");
    auto w = net::WebServer::create(wo);
    if (!w) return failure("run", w.error().what());
    out.web = std::move(*w);
    out.where += "; browser viewer on http://" + out.web->endpoint() + "/";
    if (!out.web->has_skin())
      std::fprintf(stderr, "mimic run: this build has no WebAssembly skin (no Emscripten): the page says so\n");
  }
  return -1;
}

// Everything after the scene: the network last, so every option and source is checked before a
// port is taken (a bad one is named as such even when another program holds the port).
int open_outputs(const RunOptions& o, Outputs& out) {
  if (int rc = open_scene_output(o, out); rc >= 0) return rc;
#if MIMIC_HAVE_NATS
  if (o.nats_out) {
    net::NatsOptions no = o.nats_options;
    no.servers = o.nats;
    char host[256] = {};
    if (no.name.empty()) no.name = ::gethostname(host, sizeof host - 1) == 0 && host[0] ? host : "mimic";
    net::nats_credentials_from_env(no);
    auto p = net::NatsPublisher::create(no);
    if (!p) return failure("run", p.error().what());
    out.nats = std::move(*p);
    const std::string shown = net::nats_display_servers(no.servers);
    out.where += "; publishing scene '" + no.scene + "' as '" + no.name + "' through " + shown;
    if (!out.nats->connected())
      std::fprintf(
          stderr, "mimic run: NATS broker %s not reachable: serving the local listeners, joining it when it comes up\n",
          shown.c_str());
  }
#endif
  if (o.vmc_out) {
    auto v = net::VmcSender::open(o.vmc);
    if (!v) return failure("run", v.error().what());
    out.vmc = std::move(*v);
  }
  if (o.vrpn_out) {
    auto v = net::VrpnServer::create(o.vrpn);
    if (!v) return failure("run", v.error().what());
    out.vrpn = std::move(*v);
  }
  return -1;
}

// The scene's avatars into the pipeline (announced to every sink); -1 when done.
int add_avatars(Scene& scene, long mesh_lod, Pipeline& pipeline, size_t& model_bytes_total) {
  for (size_t i = 0; i < scene.avatars.size(); ++i) {
    SceneAvatar& av = scene.avatars[i];
    const uint16_t dofs = static_cast<uint16_t>(av.feed->skeleton().dof_count());
    const auto* mesh = av.deformer->mesh();
    std::fprintf(stderr,
                 "mimic run: avatar %zu: %s; body '%s', model %zu bytes; pose frame %zu bytes; mesh LOD %ld %zu "
                 "vertices %zu triangles\n",
                 i + 1, av.feed->describe().c_str(), av.body.model.name.c_str(), av.body.bytes.size(),
                 net::pose_packet_bytes(dofs), mesh_lod, mesh ? mesh->positions.size() : 0,
                 mesh ? mesh->triangle_count() : 0);
    model_bytes_total += av.body.bytes.size();
    if (auto st = pipeline.add_avatar("avatar" + std::to_string(i + 1), std::move(av.feed), std::move(av.body.bytes),
                                      std::move(av.deformer));
        !st)
      return failure("run", st.error().what());
  }
  return -1;
}

// The loop's own health, beside the pipeline's counters.
struct LoopStats {
  uint64_t loop_allocations = 0;
  uint64_t missed_ticks = 0;  // frame periods the loop did not run in (a busy machine, a stall)
  double longest_gap_ms = 0;
  size_t model_bytes = 0;
};

// The browser viewer's part of the summary: where, and what it served and refused.
nlohmann::json web_summary(const net::WebServer& web) {
  const auto ws = web.stats();
  return {{"endpoint", web.endpoint()},
          {"skin", web.has_skin()},
          {"requests", ws.http_requests},
          {"files_served", ws.files_served},
          {"not_found", ws.not_found},
          {"bad_requests", ws.bad_requests},
          {"ws_accepted", ws.ws_accepted},
          {"ws_refused", ws.ws_refused},
          {"ws_bad_messages", ws.ws_bad_messages},
          {"ws_not_subscriber", ws.ws_not_subscriber},
          {"ws_open", ws.ws_open},
          {"scene_unreachable", ws.scene_unreachable},
          {"bytes_to_browsers", ws.bytes_to_browsers},
          {"bytes_from_browsers", ws.bytes_from_browsers}};
}

// The --json summary (also printed on SIGUSR1).
nlohmann::json summary(Pipeline& pipeline, const Outputs& out, const LoopStats& loop, double elapsed) {
  const net::VrpnServer* vrpn = out.vrpn.get();
  const net::Server* server = out.server.get();
  const net::NatsPublisher* nats = out.nats.get();
  const uint64_t loop_allocations = loop.loop_allocations, missed_ticks = loop.missed_ticks;
  const double longest_gap_ms = loop.longest_gap_ms;
  const size_t model_bytes_total = loop.model_bytes;
  nlohmann::json j;
  j["duration_s"] = elapsed;
  j["avatars"] = pipeline.avatar_count();
  j["frames"] = pipeline.frames();
  j["fps"] = double(pipeline.frames()) / std::max(elapsed, 1e-9) / double(std::max<size_t>(1, pipeline.avatar_count()));
  j["send_failures"] = pipeline.send_failures();
  j["silent_sources"] = pipeline.silent_sources();  // their last pose repeats, flagged stale
  j["stale_frames"] = pipeline.stale_frames();
  j["loop_allocations"] = loop_allocations;
  j["missed_ticks"] = missed_ticks;
  j["longest_gap_ms"] = longest_gap_ms;
  j["model_bytes"] = model_bytes_total;
  // Each avatar's source: its state and counters (records, bad input skipped, reconnects).
  j["sources"] = nlohmann::json::array();
  for (size_t i = 0; i < pipeline.avatar_count(); ++i) {
    const devices::DeviceStatus st = pipeline.feed(i).status();
    static const char* kStates[] = {"disconnected", "connecting", "streaming", "stale", "error"};
    j["sources"].push_back({{"description", st.description},
                            {"state", kStates[static_cast<int>(st.state)]},
                            {"records", st.records},
                            {"resyncs", st.resyncs},
                            {"reconnects", st.reconnects},
                            {"last_error", st.last_error}});
  }
  for (int s = 0; s < kStageCount; ++s) {
    const auto sum = pipeline.timer(s).summary();
    j["stages"][stage_name(s)] = {
        {"p50_us", sum.p50_us}, {"p99_us", sum.p99_us}, {"max_us", sum.max_us}, {"count", sum.count}};
  }
  if (vrpn) {
    const auto st = vrpn->stats();
    j["vrpn"] = {{"endpoint", vrpn->endpoint()},
                 {"connections", st.connections},
                 {"clients", st.clients},
                 {"reports", st.reports},
                 {"udp_datagrams", st.udp_datagrams},
                 {"frames_dropped", st.frames_dropped},
                 {"pongs", st.pongs},
                 {"refused", st.refused}};
  }
  if (server) {
    const auto& st = server->stats();
    j["server"] = {{"endpoint", server->endpoint()},
                   {"sessions_accepted", st.sessions_accepted},
                   {"subscribers", st.subscribers},
                   {"frames_out", st.frames_out},
                   {"frames_dropped", st.frames_dropped},
                   {"bytes_out", st.bytes_out},
                   {"rejected", st.rejected_total()},
                   {"resumed", st.resumed},
                   {"udp", server->udp()},
                   {"udp_registered", st.udp_registered},
                   {"udp_frames_out", st.udp_frames_out},
                   {"udp_challenges", st.udp_challenges},
                   {"udp_wrong_address", st.udp_wrong_address},
                   {"udp_expired", st.udp_expired},
                   {"sessions_open", st.sessions_open},
                   {"sessions_timed_out", st.sessions_timed_out},
                   {"sessions_refused_per_address", st.sessions_refused_per_address},
                   {"sessions_closed_slow", st.sessions_closed_slow},
                   {"model_bytes_held", st.model_bytes_held},
                   {"key_requests", st.key_requests},
                   {"mesh_frames_out", st.mesh_frames_out},
                   {"models_refused", st.models_refused},
                   {"mesh_topologies_refused", st.mesh_topologies_refused},
                   {"sessions_out_of_memory", st.sessions_out_of_memory},
                   {"udp_own_address", st.udp_own_address},
                   {"udp_answers_limited", st.udp_answers_limited},
                   {"accept_errors", st.accept_errors},
                   {"secret_backoffs", st.secret_backoffs},
                   {"poll_budget_hit", st.poll_budget_hit},
                   {"max_sessions", st.max_sessions_effective}};
    for (int r = 1; r < net::kRejectCount; ++r)
      if (st.rejected[size_t(r)])
        j["server"]["rejected_by_reason"][net::reject_name(net::Reject(r))] = st.rejected[size_t(r)];
  }
  if (out.web) j["http"] = web_summary(*out.web);
#if MIMIC_HAVE_NATS
  if (nats) {
    const auto ns = nats->stats();
    j["nats"] = {{"connected", ns.connected},
                 {"frames", ns.frames},
                 {"frames_dropped", ns.frames_dropped},
                 {"models", ns.models},
                 {"model_failures", ns.model_failures},
                 {"mesh_frames", ns.mesh_frames},
                 {"mesh_requests", ns.mesh_requests},
                 {"topologies", ns.topologies},
                 {"topologies_refused", ns.topologies_refused},
                 {"disconnects", ns.disconnects},
                 {"reconnects", ns.reconnects},
                 {"last_error", ns.last_error}};
  }
#else
  (void)nats;
#endif
  return j;
}

// Announces the priority the loop got, then the endpoint (handlers first: whoever reads that
// line may signal at once).
void start_loop(const RunOptions& o, const Outputs& out, const Pipeline& pipeline) {
  if (out.vrpn)
    std::fprintf(stderr, "mimic run: VRPN trackers Avatar0..%zu and Sensors0..%zu on %s\n", pipeline.avatar_count() - 1,
                 pipeline.avatar_count() - 1, out.vrpn->endpoint().c_str());
  if (o.rt_priority > 0 && !set_thread_fifo(int(o.rt_priority)))
    std::fprintf(stderr, "mimic run: SCHED_FIFO priority %ld refused (needs CAP_SYS_NICE); running unprioritised\n",
                 o.rt_priority);
  // Without --realtime the loop still asks for a raised priority (nice -10) where the system
  // permits it, so other work on a busy machine does not take its ticks.
  if (o.rt_priority == 0 && !raise_thread_nice(kLoopNice))
    std::fprintf(stderr,
                 "mimic run: raised priority refused (nice %d needs CAP_SYS_NICE or RLIMIT_NICE); "
                 "a busy machine may delay frames (missed ticks are counted)\n",
                 kLoopNice);
  clear_stop_request();
  g_report = false;
  install_stop_handler();
  std::signal(SIGUSR1, on_report_signal);
  std::printf("%s\n", out.where.c_str());
  std::fflush(stdout);
  if (out.server)
    std::fprintf(stderr, "mimic run: watch it with: mimic view --connect %s\n", out.server->endpoint().c_str());
}

// Until Ctrl-C, --duration or the remote scene ends; returns the seconds it ran.
double run_loop(const RunOptions& o, bool status_line, Pipeline& pipeline, const Outputs& out, LoopStats& loop) {
  // Sleep between passes: new samples wait at most about this long (plus the timer slack).
  constexpr int kIdleUs = 100;
  // Allocations inside the frame work (read → send), counted once the first frames have warmed
  // every buffer up; the network servicing between frames (joins, leaves) may allocate.
  constexpr uint64_t kWarmupFrames = 100;
  using C = std::chrono::steady_clock;
  const auto start = C::now();
  StatusLine status(stderr);
  uint64_t last_frames = 0;
  auto last_status = start, last_pass = start;
  while (!stop_requested()) {
    const auto now = C::now();
    if (o.duration_s > 0 && now - start >= std::chrono::duration<double>(o.duration_s)) break;
    if (const auto gap = now - last_pass; gap > 2 * kTickPeriod) {
      loop.missed_ticks += uint64_t(gap / kTickPeriod) - 1;
      loop.longest_gap_ms = std::max(loop.longest_gap_ms, std::chrono::duration<double, std::milli>(gap).count());
    }
    last_pass = now;
    const uint64_t allocs_before = thread_allocation_count();
    const bool warm = pipeline.frames() >= kWarmupFrames;
    pipeline.tick();
    if (warm) loop.loop_allocations += thread_allocation_count() - allocs_before;
    if (auto st = pipeline.service_network(kIdleUs); !st) {
      std::fprintf(stderr, "\nmimic run: %s\n", st.error().what().c_str());
      break;
    }
    if (g_report.exchange(false)) {
      // On request (SIGUSR1): the same JSON as at exit, one line on stdout.
      std::printf("%s\n",
                  summary(pipeline, out, loop, std::chrono::duration<double>(C::now() - start).count()).dump().c_str());
      std::fflush(stdout);
    }
    if (status_line && status.due(C::now())) {
      const double dt = std::chrono::duration<double>(C::now() - last_status).count();
      const size_t avatars = std::max<size_t>(1, pipeline.avatar_count());
      const double fps = double(pipeline.frames() - last_frames) / std::max(dt, 1e-9) / double(avatars);
      last_frames = pipeline.frames();
      last_status = C::now();
      write_status(status, pipeline, out.server.get(), out.nats.get(), fps, loop.missed_ticks, loop.longest_gap_ms);
    }
  }
  if (status_line) status.finish();
  return std::chrono::duration<double>(C::now() - start).count();
}

int run(const std::vector<std::string>& argv) {
  cli::Parser p("run", kRunAbout);
  RunOptions o;
  if (auto exit_code = parse_run_options(p, argv, o)) return *exit_code;
  // Setup: everything is allocated here, before the loop.
  auto scene = build_scene(o.scene);
  if (!scene)
    return scene.error().usage ? usage_error("run", scene.error().message) : failure("run", scene.error().message);
  for (const std::string& note : scene->notes) std::fprintf(stderr, "mimic run: %s\n", note.c_str());
  Outputs out;
  if (int rc = open_outputs(o, out); rc >= 0) return rc;
  Pipeline pipeline(out.sinks());
  LoopStats loop;
  if (int rc = add_avatars(*scene, o.scene.mesh_lod, pipeline, loop.model_bytes); rc >= 0) return rc;
  // --realtime: the CPUs also stay out of deep idle states while the loop runs (it naps between
  // passes, and a CPU woken from one ran the solve and the deform a third slower).
  std::optional<CpuWakeupLatency> wakeup;
  if (o.rt_priority > 0 && !wakeup.emplace(0).ok())
    std::fprintf(stderr,
                 "mimic run: the CPU wake-up latency request was refused (/dev/cpu_dma_latency needs root); idle CPUs "
                 "may wake slowly\n");
  start_loop(o, out, pipeline);
  const double elapsed = run_loop(o, !o.quiet, pipeline, out, loop);
  wakeup.reset();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::signal(SIGUSR1, SIG_DFL);
  std::fprintf(stderr, "mimic run: stopped after %.1f s, %llu frames\n", elapsed,
               static_cast<unsigned long long>(pipeline.frames()));
  if (o.json) std::printf("%s\n", summary(pipeline, out, loop, elapsed).dump().c_str());
  if (out.publisher) out.publisher->close();
  out.nats.reset();  // a clean leave: this publisher's avatars leave the scene
  return 0;
}

}  // namespace

MIMIC_COMMAND(run, "run", "run the realtime pipeline and serve the avatars", run);

}  // namespace mimic::app::cmd_run
