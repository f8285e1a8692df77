// mimic bench: measured figures on this machine. Each section is one function in the table
// below; sections print a human summary, or with --json one object per section.
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/loopback_bench.h"
#include "mimic/net/server.h"
#include "mimic/net/vmc.h"
#include "pipeline.h"

namespace mimic::app {
namespace {

struct BenchOptions {
  bool quick = false;
  long subscribers = 1000;
  long avatars = 1;
  double seconds = 3.0;
};

// ---- network -----------------------------------------------------------------------------------

Result<nlohmann::json> bench_net(const BenchOptions& opt) {
  nlohmann::json j;
  auto sk = avatar::Skeleton::build(avatar::default_skeleton_desc());
  if (!sk) return tl::unexpected(sk.error());

  // Bytes per avatar-frame: the same walking pose three ways.
  auto motion = avatar::make_builtin_motion("walk", *sk);
  if (!motion) return tl::unexpected(motion.error());
  avatar::Pose pose = sk->zero_pose();
  (*motion)->sample(0.3, pose);
  std::vector<uint8_t> frame(net::kMaxDatagramBytes), bundle;
  const size_t mimic_bytes = net::encode_pose({1, 0, 1, net::wall_clock_us()}, pose, frame);
  net::VmcEncoder(*sk).encode(pose, 0.3, bundle);
  const size_t raw_bytes = 24 + 4 * (3 + 4 + pose.dof_rad.size());
  j["bytes_per_avatar_frame"] = {{"mimic", mimic_bytes}, {"vmc", bundle.size()}, {"raw_float", raw_bytes},
                                 {"dofs", pose.dof_rad.size()}};
  std::fprintf(stderr, "bytes per avatar-frame (%zu DOFs): mimic %zu, VMC %zu (%.1fx), raw float %zu (%.1fx)\n",
               pose.dof_rad.size(), mimic_bytes, bundle.size(), double(bundle.size()) / double(mimic_bytes), raw_bytes,
               double(raw_bytes) / double(mimic_bytes));

  // Server -> subscriber over loopback.
  auto lat = net::measure_loopback_latency(opt.quick ? 300 : 3000, uint16_t(sk->dof_count()));
  if (!lat) return tl::unexpected(lat.error());
  j["loopback_latency_us"] = {{"p50", lat->p50_us}, {"p99", lat->p99_us}, {"max", lat->max_us}, {"samples", lat->samples}};
  std::fprintf(stderr, "server -> subscriber on loopback: p50 %.1f us, p99 %.1f us (%llu frames)\n", lat->p50_us,
               lat->p99_us, static_cast<unsigned long long>(lat->samples));

  // Sensor record -> frame leaving the socket: the pipeline of `mimic run` on the simulated
  // walk (tracker sample through solver, deformer, encoder and server), one subscriber reading.
  // The loop is run's: it sleeps 100 us between passes; measured at normal priority and at
  // SCHED_FIFO 50 (mimic run --realtime 50) when the system allows it.
  auto pipeline_latency = [&](int slice_us, int rt_priority) -> Result<nlohmann::json> {
    auto server = net::Server::create({});
    if (!server) return tl::unexpected(server.error());
    auto feed = open_feed("sim:walk?rate=90");
    if (!feed) return tl::unexpected(feed.error());
    auto body = load_body("");
    if (!body) return tl::unexpected(body.error());
    auto skin = make_skin_deformer(body->model, (*feed)->skeleton(), 2);
    if (!skin) return tl::unexpected(skin.error());
    Pipeline pipeline({server->get(), nullptr, nullptr});
    if (auto st = pipeline.add_avatar("bench", std::move(*feed), std::move(body->bytes), std::move(*skin)); !st)
      return tl::unexpected(st.error());
    std::atomic<bool> stop{false};
    const std::string ep = (*server)->endpoint();
    std::thread viewer([&] {
      net::ClientOptions co;
      co.connect = ep;
      auto c = net::Client::connect(co);
      while (c && !stop) (void)(*c)->run_until(std::chrono::steady_clock::now() + std::chrono::milliseconds(20));
    });
    using C = std::chrono::steady_clock;
    const bool rt = rt_priority > 0 && set_realtime_priority(rt_priority);
    if (rt_priority > 0 && !rt) {
      stop = true;
      viewer.join();
      return nlohmann::json{{"refused", true}};
    }
    const auto end = C::now() + std::chrono::duration<double>(opt.quick ? 1.0 : opt.seconds);
    while (C::now() < end) {
      pipeline.tick();
      (void)service_network({server->get(), nullptr, nullptr}, slice_us);
    }
    if (rt) set_realtime_priority(0);
    stop = true;
    viewer.join();
    const auto s = pipeline.timer(kStageLatency).summary();
    nlohmann::json stages;
    for (int k = 0; k < kStageCount; ++k) {
      const auto ks = pipeline.timer(k).summary();
      stages[stage_name(k)] = {{"p50_us", ks.p50_us}, {"p99_us", ks.p99_us}};
    }
    std::fprintf(stderr, "sensor record -> frame leaving the socket (%s): p50 %.0f us, p99 %.0f us (%llu frames)\n",
                 rt ? "mimic run --realtime 50" : "mimic run loop", s.p50_us, s.p99_us,
                 static_cast<unsigned long long>(s.count));
    return nlohmann::json{{"p50", s.p50_us}, {"p99", s.p99_us}, {"frames", s.count}, {"stages", stages}};
  };
  auto run_loop = pipeline_latency(100, 0);
  if (!run_loop) return tl::unexpected(run_loop.error());
  j["record_to_socket_us"] = *run_loop;
  auto prioritised = pipeline_latency(100, 50);
  if (!prioritised) return tl::unexpected(prioritised.error());
  j["record_to_socket_realtime_us"] = *prioritised;

  // Fan-out at 90 Hz: subscribers x avatars streams with no lost latest frame.
  nlohmann::json sweep = nlohmann::json::array();
  std::vector<std::pair<long, long>> configs;
  if (opt.quick) configs = {{10, 1}, {50, 2}};
  else configs = {{100, 1}, {250, 2}, {250, 4}, {500, 2}, {opt.subscribers, opt.avatars}};
  long best = 0;
  for (const auto& [subs, avs] : configs) {
    auto r = net::measure_fanout(int(subs), int(avs), 90.0, opt.quick ? 0.5 : opt.seconds);
    if (!r) return tl::unexpected(r.error());
    sweep.push_back({{"subscribers", subs},
                     {"avatars", avs},
                     {"streams", subs * avs},
                     {"expected", r->frames_expected},
                     {"received", r->frames_received},
                     {"dropped", r->frames_dropped},
                     {"lost", r->lost},
                     {"tick_p50_us", r->tick_p50_us},
                     {"tick_p99_us", r->tick_p99_us},
                     {"achieved_rate_hz", r->achieved_rate_hz},
                     {"late_ticks", r->late_ticks},
                     {"kept_up", r->kept_up}});
    std::fprintf(stderr, "fan-out 90 Hz: %ld subscribers x %ld avatars = %ld streams: %s at %.1f Hz (received %llu/%llu, dropped %llu, tick p99 %.0f us)\n",
                 subs, avs, subs * avs, r->kept_up ? "kept up" : "FELL BEHIND", r->achieved_rate_hz,
                 static_cast<unsigned long long>(r->frames_received), static_cast<unsigned long long>(r->frames_expected),
                 static_cast<unsigned long long>(r->frames_dropped), r->tick_p99_us);
    if (r->kept_up) best = std::max(best, subs * avs);
  }
  j["fanout_90hz"] = sweep;
  j["max_streams_kept_up"] = best;
  return j;
}

struct Section {
  const char* name;
  Result<nlohmann::json> (*run)(const BenchOptions&);
};

const Section kSections[] = {
    {"net", bench_net},
};

const char* kUsage =
    "usage: mimic bench [--section NAME] [--quick] [--subscribers N] [--avatars A] [--seconds S] [--json]\n"
    "\n"
    "Measures this machine (figures, not pass/fail; a loaded machine measures worse).\n"
    "\n"
    "sections:\n"
    "  net   bytes per avatar-frame (Mimic pose frame vs VMC vs raw floats); server -> subscriber\n"
    "        latency on loopback; sensor record -> frame leaving the socket through the mimic run\n"
    "        pipeline (p50/p99); subscribers x avatars the server holds at 90 Hz with no lost\n"
    "        latest frame\n"
    "\n"
    "options:\n"
    "  --section NAME    run one section (default: all)\n"
    "  --quick           a short smoke pass\n"
    "  --subscribers N   largest fan-out point: subscribers (default 1000)\n"
    "  --avatars A       largest fan-out point: avatars (default 1)\n"
    "  --seconds S       duration of each timed run (default 3)\n"
    "  --json            print one JSON object {section: figures} on stdout\n";

int bench(const std::vector<std::string>& argv) {
  Args a(argv, {"section", "subscribers", "avatars", "seconds"}, {"quick", "json"});
  if (a.help()) {
    std::printf("%s", kUsage);
    return 0;
  }
  if (!a.ok()) return usage_error("bench", a.error());
  BenchOptions opt;
  opt.quick = a.has("quick");
  if (!a.get_int("subscribers", opt.subscribers) || !a.get_int("avatars", opt.avatars) ||
      !a.get_double("seconds", opt.seconds))
    return usage_error("bench", a.error());
  if (opt.subscribers < 1 || opt.avatars < 1 || opt.seconds <= 0)
    return usage_error("bench", "--subscribers, --avatars and --seconds must be positive");
  const std::string only = a.get_or("section", "");
  nlohmann::json all;
  bool found = false;
  for (const auto& s : kSections) {
    if (!only.empty() && only != s.name) continue;
    found = true;
    std::fprintf(stderr, "== %s\n", s.name);
    auto r = s.run(opt);
    if (!r) return failure("bench", std::string(s.name) + ": " + r.error().what());
    all[s.name] = *r;
  }
  if (!found) return usage_error("bench", "unknown section '" + only + "'");
  if (a.has("json")) std::printf("%s\n", all.dump().c_str());
  return 0;
}

}  // namespace

MIMIC_COMMAND(bench, "bench", "measure latency, throughput and sizes on this machine", kUsage, bench);

}  // namespace mimic::app
