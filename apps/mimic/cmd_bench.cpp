// mimic bench: measured figures on this machine. Each section is one function in the table
// below; sections print a human summary, or with --json one object per section.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "bench_pipeline.h"
#include "bench_web.h"
#include "cli.h"
#include "command.h"
#include "mimic/core/percentile.h"
#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic/bench/loopback_bench.h"
#include "mimic/core/thread_priority.h"
#include "mimic/net/server.h"
#include "mimic/net/vmc.h"
#include "mimic/avatar/baselines/baseline_skinner.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/sim/sensor_rig.h"
#include "mimic/solver/body_solver.h"
#include "mimic/solver/filters.h"
#include "mimic/service/pipeline.h"

namespace mimic::app::cmd_bench {
using namespace ::mimic::service;
namespace {

struct BenchOptions {
  bool quick = false;
  long subscribers = 1000;
  long avatars = 1;
  double seconds = 3.0;
  bool fanout_point = false;  // --subscribers or --avatars given: the fan-out section runs only that point
  std::string transport;      // fan-out: "tcp", "udp" or empty for every transport
  long realtime = 0;          // fan-out: SCHED_FIFO priority of the server and receiving threads
  long threads = 0;           // fan-out: the server's threads sharing a tick's writes (0: its default)
  long receivers = 2;         // fan-out: threads reading the subscribers
  bool json_lines =
      false;  // skin, solver or fan-out alone with --json: one object per LOD, layout or configuration per line
};

// ---- network -----------------------------------------------------------------------------------

// Bytes per avatar-frame: the same walking pose three ways.
Status bytes_per_frame(const rig::Skeleton& sk, nlohmann::json& j) {
  auto motion = rig::make_builtin_motion("walk", sk);
  if (!motion) return tl::unexpected(motion.error());
  rig::Pose pose = sk.zero_pose();
  (*motion)->sample(0.3, pose);
  std::vector<uint8_t> frame(net::kMaxDatagramBytes), bundle;
  const size_t mimic_bytes = net::encode_pose({1, 0, 1, net::wall_clock_us()}, pose, frame);
  net::VmcEncoder(sk).encode(pose, 0.3, bundle);
  const size_t raw_bytes = 24 + 4 * (3 + 4 + pose.dof_rad.size());
  j["bytes_per_avatar_frame"] = {
      {"mimic", mimic_bytes}, {"vmc", bundle.size()}, {"raw_float", raw_bytes}, {"dofs", pose.dof_rad.size()}};
  std::fprintf(stderr, "bytes per avatar-frame (%zu DOFs): mimic %zu, VMC %zu (%.1fx), raw float %zu (%.1fx)\n",
               pose.dof_rad.size(), mimic_bytes, bundle.size(), double(bundle.size()) / double(mimic_bytes), raw_bytes,
               double(raw_bytes) / double(mimic_bytes));
  return {};
}

// Server -> subscriber over loopback, frames on the stream and as UDP datagrams.
Status loopback_latency(const BenchOptions& opt, const rig::Skeleton& sk, nlohmann::json& j) {
  auto lat = bench::measure_loopback_latency(opt.quick ? 300 : 3000, uint16_t(sk.dof_count()));
  if (!lat) return tl::unexpected(lat.error());
  j["loopback_latency_us"] = {
      {"p50", lat->p50_us}, {"p99", lat->p99_us}, {"max", lat->max_us}, {"samples", lat->samples}};
  std::fprintf(stderr, "server -> subscriber on loopback: p50 %.1f us, p99 %.1f us (%llu frames)\n", lat->p50_us,
               lat->p99_us, static_cast<unsigned long long>(lat->samples));
  auto lat_udp = bench::measure_loopback_latency(opt.quick ? 300 : 3000, uint16_t(sk.dof_count()), true);
  if (!lat_udp) return tl::unexpected(lat_udp.error());
  j["loopback_latency_udp_us"] = {
      {"p50", lat_udp->p50_us}, {"p99", lat_udp->p99_us}, {"max", lat_udp->max_us}, {"samples", lat_udp->samples}};
  std::fprintf(stderr, "server -> subscriber on loopback, frames as UDP datagrams: p50 %.1f us, p99 %.1f us\n",
               lat_udp->p50_us, lat_udp->p99_us);
  return {};
}

// Fan-out at 90 Hz: subscribers x avatars streams with no lost latest frame.
Status fanout_sweep(const BenchOptions& opt, nlohmann::json& j) {
  nlohmann::json sweep = nlohmann::json::array();
  std::vector<std::pair<long, long>> configs;
  if (opt.quick)
    configs = {{10, 1}, {50, 2}};
  else
    configs = {{100, 1}, {250, 2}, {250, 4}, {500, 2}, {opt.subscribers, opt.avatars}};
  long best = 0;
  for (const auto& [subs, avs] : configs) {
    auto r = bench::measure_fanout(int(subs), int(avs), 90.0, opt.quick ? 0.5 : opt.seconds);
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
    std::fprintf(stderr,
                 "fan-out 90 Hz: %ld subscribers x %ld avatars = %ld streams: %s at %.1f Hz (received %llu/%llu, "
                 "dropped %llu, tick p99 %.0f us)\n",
                 subs, avs, subs * avs, r->kept_up ? "kept up" : "FELL BEHIND", r->achieved_rate_hz,
                 static_cast<unsigned long long>(r->frames_received),
                 static_cast<unsigned long long>(r->frames_expected),
                 static_cast<unsigned long long>(r->frames_dropped), r->tick_p99_us);
    if (r->kept_up) best = std::max(best, subs * avs);
  }
  j["fanout_90hz"] = sweep;
  j["max_streams_kept_up"] = best;
  return {};
}

Result<nlohmann::json> bench_net(const BenchOptions& opt) {
  nlohmann::json j;
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  if (!sk) return tl::unexpected(sk.error());
  if (auto st = bytes_per_frame(*sk, j); !st) return tl::unexpected(st.error());
  if (auto st = loopback_latency(opt, *sk, j); !st) return tl::unexpected(st.error());
  const double seconds = opt.quick ? 1.0 : opt.seconds;
  auto run_loop = pipeline_latency("sim", seconds, 100, 0);
  if (!run_loop) return tl::unexpected(run_loop.error());
  j["record_to_socket_us"] = *run_loop;
  auto prioritised = pipeline_latency("sim", seconds, 100, 50);
  if (!prioritised) return tl::unexpected(prioritised.error());
  j["record_to_socket_realtime_us"] = *prioritised;
  // The trackers people own: a VRPN report, a VMC bundle read from the socket -> frame out.
  for (const char* input : {"vrpn", "vmc"}) {
    auto r = pipeline_latency(input, seconds, 100, 0);
    if (!r) return tl::unexpected(r.error());
    j[std::string(input) + "_to_socket_us"] = *r;
  }
  if (auto st = fanout_sweep(opt, j); !st) return tl::unexpected(st.error());
  return j;
}

// ---- skin ---------------------------------------------------------------------------------------

// Median and 99th percentile of a set of durations (microseconds); reorders them.
std::pair<double, double> p50_p99(std::vector<double>& us) {
  return {percentile_in_place(us, 0.50), percentile_in_place(us, 0.99)};
}

template <class F>
std::vector<double> time_frames(double seconds, size_t max_frames, F&& frame) {
  using clock = std::chrono::steady_clock;
  std::vector<double> us;
  us.reserve(max_frames);
  const auto end = clock::now() + std::chrono::duration<double>(seconds);
  for (size_t k = 0; k < max_frames && (k < 10 || clock::now() < end); ++k) {
    const auto t0 = clock::now();
    frame(k);
    us.push_back(std::chrono::duration<double, std::micro>(clock::now() - t0).count());
  }
  return us;
}

// The skin at every LOD on the built-in walk, in one run: the full method (every contour
// ray-cast, contour points as vertices), the realtime method without and with its muscle terms,
// and the baseline skinnings (LBS, DQS, CoR) of the same vertices; one row per LOD.
struct SkinBenchCase {
  int lod = 0;
  avatar::ImplicitSkin full;
  std::shared_ptr<const avatar::RealtimeBody> body;
  std::vector<rig::Pose> poses;
};

nlohmann::json skin_row(SkinBenchCase& c, double seconds) {
  const rig::Skeleton& sk = c.full.skeleton();
  const avatar::Mesh& rest = c.body->rest_mesh();
  const size_t np = c.poses.size();
  auto median = [](std::vector<double> us) { return p50_p99(us).first; };
  const double full_us = median(time_frames(seconds, 200000, [&](size_t k) { c.full.evaluate(c.poses[k % np]); }));
  avatar::RealtimeSkin rt(c.body);
  std::vector<glm::vec3> out(rest.positions.size());
  const double rt_us =
      median(time_frames(seconds, 2000000, [&](size_t k) { rt.evaluate(c.poses[k % np], out, {}, false, false); }));
  const double rtm_us =
      median(time_frames(seconds, 2000000, [&](size_t k) { rt.evaluate(c.poses[k % np], out, {}, true, false); }));
  // The default: muscles and contact (docs/skin.md, "Contact").
  const double rtc_us =
      median(time_frames(seconds, 2000000, [&](size_t k) { rt.evaluate(c.poses[k % np], out, {}, true, true); }));
  // The baselines on the same rest mesh, bound with the contour-derived weights; a frame is FK,
  // the joints' skinning transforms, then the vertices.
  std::vector<rig::RigidTransform> w(sk.joint_count());
  rig::forward_kinematics(sk, sk.zero_pose(), w);
  auto baselines =
      avatar::baselines::BaselineSkinner::create(sk, w, rest, avatar::baselines::from_influences(c.body->weights()));
  if (!baselines) return {{"lod", c.lod}, {"error", baselines.error().what()}};
  auto baseline_us = [&](avatar::baselines::SkinningMethod m) {
    return median(time_frames(seconds, 2000000, [&](size_t k) {
      rig::forward_kinematics(sk, c.poses[k % np], w);
      baselines->set_pose(w);
      baselines->deform(m, out);
    }));
  };
  const double lbs_us = baseline_us(avatar::baselines::SkinningMethod::lbs);
  const double dqs_us = baseline_us(avatar::baselines::SkinningMethod::dqs);
  const double cor_us = baseline_us(avatar::baselines::SkinningMethod::cor);
  // The vertex loops alone (no FK, no per-joint conversion), per vertex.
  auto vertices_ns = [&](avatar::baselines::SkinningMethod m) {
    return 1000.0 * median(time_frames(seconds, 2000000, [&](size_t) { baselines->deform(m, out); })) /
           static_cast<double>(rest.positions.size());
  };
  const double lbs_ns = vertices_ns(avatar::baselines::SkinningMethod::lbs);
  const double dqs_ns = vertices_ns(avatar::baselines::SkinningMethod::dqs);
  const double cor_ns = vertices_ns(avatar::baselines::SkinningMethod::cor);
  // Accuracy against the full method on the same poses (same vertices, in order).
  double sum[2] = {0, 0}, worst[2] = {0, 0}, contact_moved = 0;
  for (const rig::Pose& p : c.poses) {
    c.full.evaluate(p);
    for (int muscles = 0; muscles < 2; ++muscles) {
      // As timed: without muscles the paper's method alone, with them the default (contact too).
      rt.evaluate(p, out, {}, muscles == 1, muscles == 1);
      if (muscles == 1) contact_moved += static_cast<double>(rt.contact_moved());
      for (size_t v = 0; v < out.size(); ++v) {
        const double d = glm::distance(out[v], c.full.mesh().positions[v]);
        sum[muscles] += d;
        worst[muscles] = std::max(worst[muscles], d);
      }
    }
  }
  const double samples = static_cast<double>(c.poses.size() * out.size());
  return {{"lod", c.lod},
          {"vertices", rest.positions.size()},
          {"triangles", rest.triangle_count()},
          {"full_us", full_us},
          {"realtime_us", rt_us},
          {"realtime_muscles_us", rtm_us},
          {"realtime_contact_us", rtc_us},
          {"contact_pairs", c.body->contact_pairs()},
          {"contact_vertices", c.body->contact_vertices()},
          {"contact_moved_per_frame", contact_moved / static_cast<double>(c.poses.size())},
          {"lbs_us", lbs_us},
          {"dqs_us", dqs_us},
          {"cor_us", cor_us},
          {"lbs_ns_per_vertex", lbs_ns},
          {"dqs_ns_per_vertex", dqs_ns},
          {"cor_ns_per_vertex", cor_ns},
          {"muscle_points", c.body->muscle_points()},
          {"shared_bytes", c.body->shared_bytes()},
          {"avatar_bytes", rt.instance_bytes()},
          {"error_mean_mm", 1000 * sum[1] / samples},
          {"error_max_mm", 1000 * worst[1]},
          {"error_mean_mm_no_muscles", 1000 * sum[0] / samples},
          {"error_max_mm_no_muscles", 1000 * worst[0]}};
}

Result<nlohmann::json> bench_skin(const BenchOptions& opt) {
  nlohmann::json rows = nlohmann::json::array();
  const double seconds = opt.quick ? 0.15 : opt.seconds / 4;
  for (int lod = 0; lod < avatar::kSkinLodCount; ++lod) {
    const avatar::BodyModel model = avatar::with_skin_lod(avatar::default_body_model(), lod);
    avatar::SkinOptions o;
    o.subdivision = 0;
    o.normals = false;
    auto full = avatar::ImplicitSkin::create(model, o);
    if (!full) return tl::unexpected(full.error());
    avatar::RealtimeOptions ro;
    ro.lod = lod;
    auto body = avatar::RealtimeBody::create(avatar::default_body_model(), full->skeleton(), ro);
    if (!body) return tl::unexpected(body.error());
    SkinBenchCase c{lod, std::move(*full), *body, {}};
    const rig::Skeleton& sk = c.full.skeleton();
    auto motion = rig::make_builtin_motion("walk", sk);
    if (!motion) return tl::unexpected(motion.error());
    c.poses.assign(64, sk.zero_pose());
    for (size_t k = 0; k < c.poses.size(); ++k) (*motion)->sample(0.02 * static_cast<double>(k), c.poses[k]);
    nlohmann::json row = skin_row(c, seconds);
    std::fprintf(stderr,
                 "skin LOD %d: %zu vertices, %zu triangles: full %.1f us, realtime %.1f us, with muscles %.1f us, "
                 "with muscles and contact %.1f us, linear blend skinning %.1f us (realtime with muscles / LBS "
                 "%.2fx, with contact / LBS %.2fx), dual quaternion %.1f us, "
                 "centres of rotation %.1f us (vertex loops: LBS %.2f, DQS %.2f, CoR %.2f ns/vertex); realtime vs "
                 "full: mean %.2f mm (%.2f mm without muscles), max %.0f mm\n",
                 lod, row["vertices"].get<size_t>(), row["triangles"].get<size_t>(), row["full_us"].get<double>(),
                 row["realtime_us"].get<double>(), row["realtime_muscles_us"].get<double>(),
                 row["realtime_contact_us"].get<double>(), row["lbs_us"].get<double>(),
                 row["realtime_muscles_us"].get<double>() / std::max(row["lbs_us"].get<double>(), 1e-9),
                 row["realtime_contact_us"].get<double>() / std::max(row["lbs_us"].get<double>(), 1e-9),
                 row["dqs_us"].get<double>(), row["cor_us"].get<double>(), row["lbs_ns_per_vertex"].get<double>(),
                 row["dqs_ns_per_vertex"].get<double>(), row["cor_ns_per_vertex"].get<double>(),
                 row["error_mean_mm"].get<double>(), row["error_mean_mm_no_muscles"].get<double>(),
                 row["error_max_mm"].get<double>());
    if (opt.json_lines) std::printf("%s\n", row.dump().c_str());
    rows.push_back(std::move(row));
  }
  return rows;
}

// ---- solver -------------------------------------------------------------------------------------

// Filtering + solving one frame of the built-in walk worn by each standard layout (the rig's
// exact mounts, 1 mm / 0.5° noise, 120 Hz).
Result<nlohmann::json> bench_solver(const BenchOptions& opt) {
  nlohmann::json j;
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  if (!sk) return tl::unexpected(sk.error());
  auto motion = rig::make_builtin_motion("walk", *sk);
  if (!motion) return tl::unexpected(motion.error());
  std::shared_ptr<const rig::Motion> shared(std::move(*motion));
  const double seconds = opt.quick ? 0.3 : opt.seconds;
  for (const std::string layout : {"3", "6", "11", "all"}) {
    auto mounts = sim::make_layout(layout, *sk);
    if (!mounts) return tl::unexpected(mounts.error());
    sim::RigConfig cfg;
    cfg.sensors = *mounts;
    cfg.rate_hz = 120.0;
    cfg.position_noise_mm = 1.0;
    cfg.orientation_noise_deg = 0.5;
    auto rig = sim::SensorRig::create(shared, cfg);
    if (!rig) return tl::unexpected(rig.error());
    std::vector<solver::SensorMount> sm;
    for (size_t i = 0; i < mounts->size(); ++i)
      sm.push_back({static_cast<uint16_t>(i), (*mounts)[i].segment, (*mounts)[i].segment_from_sensor});
    // The standing height a calibration would give: head and hands alone then have stepping legs.
    solver::SolverOptions so;
    so.standing_root_y_m = rig::standing_root_height_m(*sk);
    auto model = solver::SolverModel::create(*sk, sm, so);
    if (!model) return tl::unexpected(model.error());
    solver::SolverContext ctx(*model);
    solver::SensorFilterBank filters(static_cast<int>(sm.size()));
    rig::Pose pose = sk->zero_pose();
    // One whole lap of the walk, so that the loop is seamless: a shorter recording made the body
    // jump back to where it began at every restart, and those frames (four least-squares iterations
    // and up to three swivel searches) were the 3-sensor p99.
    const auto lap_ticks = static_cast<size_t>(std::lround(shared->duration_s() * cfg.rate_hz));
    std::vector<std::vector<devices::SensorSample>> ticks(std::max<size_t>(lap_ticks, 1),
                                                          std::vector<devices::SensorSample>(sm.size()));
    for (auto& t : ticks) rig->step(t);
    std::vector<devices::SensorSample> work(sm.size());
    auto us = time_frames(seconds, 400000, [&](size_t k) {
      const auto& t = ticks[k % ticks.size()];
      if (k % ticks.size() == 0) filters.reset();  // the recording starts again (its timestamps jump)
      std::copy(t.begin(), t.end(), work.begin());
      filters.process(work);
      solver::SolveJob job{&*model, work, &ctx, &pose};
      job.Run();
    });
    const auto [p50, p99] = p50_p99(us);
    j[layout] = {{"solve_us_p50", p50}, {"solve_us_p99", p99}, {"frames", us.size()}};
    std::fprintf(stderr, "solver, %s sensors: filter + solve p50 %.1f us, p99 %.1f us\n", layout.c_str(), p50, p99);
    if (opt.json_lines)
      std::printf(
          "%s\n",
          nlohmann::json{
              {"section", "solver"}, {"sensors", layout}, {"p50_us", p50}, {"p99_us", p99}, {"frames", us.size()}}
              .dump()
              .c_str());
  }
  return j;
}

// ---- fan-out capacity ---------------------------------------------------------------------------

// One row per (transport, subscribers, avatars). Transports measured by other modules (a broker
// relay) add their rows to this table the same way: the same columns, one JSON object each.
nlohmann::json fanout_row(const bench::FanoutCapacity& c) {
  const auto& r = c.result;
  nlohmann::json row = {{"transport", bench::fanout_transport_name(c.options.transport)},
                        {"streams", c.streams},
                        {"subscribers", c.options.subscribers},
                        {"avatars", c.options.avatars},
                        {"hz", c.options.rate_hz},
                        {"lean", c.options.lean},
                        {"realtime", c.realtime},
                        {"tick_us_p50", r.tick_p50_us},
                        {"tick_us_p99", r.tick_p99_us},
                        {"bytes_per_avatar_frame", c.bytes_per_avatar_frame},
                        {"cpu_percent", c.cpu_percent},
                        {"cpu_us_per_tick", c.cpu_us_per_tick},
                        {"receiver_cpu_us_per_tick", c.receiver_cpu_us_per_tick},
                        {"sender_threads", c.sender_threads},
                        {"receiver_threads", c.receiver_threads},
                        {"process_cpu_percent", c.process_cpu_percent},
                        {"lost", r.lost},
                        {"dropped", r.frames_dropped},
                        {"expected", r.frames_expected},
                        {"received", r.frames_received},
                        {"achieved_hz", r.achieved_rate_hz},
                        {"late_ticks", r.late_ticks},
                        {"kept_up", r.kept_up},
                        {"load_average_1m", c.load_average_1m}};
  if (c.options.transport == bench::FanoutTransport::nats) {
    row["publish_to_relay_ms_p50"] = c.publish_to_relay_ms_p50;
    row["publish_to_relay_ms_p99"] = c.publish_to_relay_ms_p99;
    row["broker_cpu_percent"] = c.broker_cpu_percent;
    row["relay_fanouts_per_tick"] = c.fanouts_per_tick;
    row["settled_after_window"] = c.settled_after_window;
  }
  return row;
}

Result<nlohmann::json> bench_fanout(const BenchOptions& opt) {
  std::vector<bench::FanoutTransport> transports;
  for (auto t : {bench::FanoutTransport::tcp, bench::FanoutTransport::udp, bench::FanoutTransport::nats})
    if (opt.transport.empty() || opt.transport == bench::fanout_transport_name(t)) transports.push_back(t);
  std::vector<std::pair<long, long>> points;
  if (opt.fanout_point)
    points = {{opt.subscribers, opt.avatars}};
  else if (opt.quick)
    points = {{50, 2}};
  else
    points = {{1000, 1}, {2500, 4}, {1250, 8}};
  nlohmann::json rows = nlohmann::json::array();
  for (auto t : transports) {
    if (t == bench::FanoutTransport::nats) {
      if (auto ready = bench::fanout_nats_available(); !ready) {
        // A row saying why, so that a reader of the JSON lines sees the transport was skipped.
        std::fprintf(stderr, "fan-out nats: skipped: %s\n", ready.error().message.c_str());
        const nlohmann::json row = {{"transport", "nats"}, {"skipped", ready.error().message}};
        if (opt.json_lines) std::printf("%s\n", row.dump().c_str());
        rows.push_back(row);
        continue;
      }
    }
    for (const auto& [subs, avs] : points) {
      bench::FanoutOptions o;
      o.subscribers = int(subs);
      o.avatars = int(avs);
      o.seconds = opt.quick ? 0.5 : opt.seconds;
      o.transport = t;
      o.realtime_priority = int(opt.realtime);
      o.sender_threads = int(opt.threads);
      o.receiver_threads = int(opt.receivers);
      auto c = bench::measure_fanout_capacity(o);
      if (!c) return tl::unexpected(c.error());
      const auto row = fanout_row(*c);
      std::fprintf(stderr,
                   "fan-out %s 90 Hz: %ld subscribers x %ld avatars = %llu streams: %s (tick p50 %.0f us, p99 %.0f us, "
                   "%.1f bytes/avatar-frame, lost %llu, dropped %llu, server %d threads %.0f%% CPU = %.0f us per tick, "
                   "receivers %.0f us per tick, load %.1f)\n",
                   bench::fanout_transport_name(t), subs, avs, static_cast<unsigned long long>(c->streams),
                   c->result.kept_up ? "kept up" : "FELL BEHIND", c->result.tick_p50_us, c->result.tick_p99_us,
                   c->bytes_per_avatar_frame, static_cast<unsigned long long>(c->result.lost),
                   static_cast<unsigned long long>(c->result.frames_dropped), c->sender_threads, c->cpu_percent,
                   c->cpu_us_per_tick, c->receiver_cpu_us_per_tick, c->load_average_1m);
      if (t == bench::FanoutTransport::nats)
        std::fprintf(stderr,
                     "  publish -> nats-server -> relay: p50 %.2f ms, p99 %.2f ms; nats-server %.0f%% CPU; %.2f relay "
                     "fan-outs per tick\n",
                     c->publish_to_relay_ms_p50, c->publish_to_relay_ms_p99, c->broker_cpu_percent,
                     c->fanouts_per_tick);
      if (opt.json_lines) std::printf("%s\n", row.dump().c_str());
      rows.push_back(row);
    }
  }
  return rows;
}

Result<nlohmann::json> bench_web_section(const BenchOptions& opt) { return bench_web::run(opt.quick); }

struct Section {
  const char* name;
  Result<nlohmann::json> (*run)(const BenchOptions&);
};

const Section kSections[] = {
    {"net", bench_net},       {"skin", bench_skin},       {"solver", bench_solver},
    {"fanout", bench_fanout}, {"web", bench_web_section},
};

constexpr const char* kAbout = "Measures this machine (figures, not pass/fail; a loaded machine measures worse).";

constexpr const char* kSectionsHelp =
    "sections:\n"
    "  net   bytes per avatar-frame (Mimic pose frame vs VMC vs raw floats); server -> subscriber\n"
    "        latency on loopback (TCP, and UDP datagrams); sensor record -> frame leaving the\n"
    "        socket through the mimic run pipeline (p50/p99), from the simulated walk, from a\n"
    "        VRPN tracker's report and from a VMC sender's bundle (its six sensors over\n"
    "        loopback UDP into vrpn: and vmc: sources); subscribers x avatars the server\n"
    "        holds at 90 Hz with no lost latest frame\n"
    "  skin  the skin on the built-in walk at every LOD, one row each: the full method\n"
    "        (contours ray-cast), the realtime method without and with muscles (no contact),\n"
    "        with muscles and contact (realtime_contact_us, the default), and the\n"
    "        baselines on the same vertices with the contour-derived weights: linear blend\n"
    "        (lbs_us), dual quaternion (dqs_us) and optimized centres of rotation (cor_us)\n"
    "        skinning (medians, microseconds, one run; lbs/dqs/cor_ns_per_vertex for their\n"
    "        vertex loops alone); and the realtime vertices' distance from the full\n"
    "        method's on the same poses (mm); with --json alone, one JSON object per LOD\n"
    "        per line\n"
    "  solver  filter + solve per frame for the layouts 3, 6, 11 and all (built-in walk,\n"
    "        1 mm / 0.5 deg noise, 120 Hz, the standing height known): p50/p99; with --json\n"
    "        alone, one JSON object per layout per line (section, sensors, p50_us, p99_us, frames)\n"
    "  fanout  subscriber streams one process serves at 90 Hz over loopback (TCP and UDP, lean\n"
    "        stream): tick p50/p99, bytes per avatar-frame, CPU, lost (from sequence numbers);\n"
    "        and through a broker (nats): the bench starts nats-server on a free loopback port,\n"
    "        publishes into it and a relay in-process serves the subscribers (tick = the relay's\n"
    "        fan-out; publish-to-relay latency p50/p99); skipped, saying why, without NATS or\n"
    "        nats-server; with --json alone, one JSON object per configuration per line\n"
    "  web   the browser viewer, against a mimic run --http child of the bench (sim:walk) on\n"
    "        loopback: the page's WebAssembly skin timed in headless Chromium at every LOD\n"
    "        against the native realtime skin on the same body and poses (page_over_native);\n"
    "        bytes a second per avatar read by subscribers of that run: lean pose stream, POSE\n"
    "        frames, mesh frames at each LOD; the page's latency from a pose's capture to its\n"
    "        draw calls submitted (p50/p99); without Chromium or the WebAssembly skin the\n"
    "        page's part says why it skipped ({\"skipped\": ...}) and the bench exits 0";

// The options; `only` the one section asked for ("" for all), `json` whether to print figures.
std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, BenchOptions& opt, std::string& only,
                         bool& json) {
  p->footer(kSectionsHelp);
  std::vector<std::string> names;
  for (const auto& s : kSections) names.push_back(s.name);
  p->add_option("--section", only, "run one section (default: all)")->type_name("NAME")->check(CLI::IsMember(names));
  p->add_flag("--quick", opt.quick, "a short smoke pass");
  auto* subs = p->add_option("--subscribers", opt.subscribers, "largest fan-out point: subscribers")
                   ->check(CLI::Range(1L, 1000000L));
  auto* avs = p->add_option("--avatars", opt.avatars, "largest fan-out point: avatars")->check(CLI::Range(1L, 1000L));
  p->add_option("--seconds", opt.seconds, "duration of each timed run")
      ->check(cli::finite_range(0, 3600, cli::Bound::exclusive));
  p->add_option("--transport", opt.transport, "fanout: this transport only")
      ->check(CLI::IsMember({"tcp", "udp", "nats"}));
  p->add_option("--realtime", opt.realtime,
                "fanout: the server's threads SCHED_FIFO at priority P, the receiving\n"
                "threads at P - 1 (0: normal priority)")
      ->type_name("P")
      ->check(CLI::Range(0L, 99L));
  p->add_option("--threads", opt.threads,
                "fanout: the server's threads sharing a tick's writes (0: one per\n"
                "core, at most 4)")
      ->check(CLI::Range(0L, 64L));
  p->add_option("--receivers", opt.receivers, "fanout: threads reading the subscribers' sockets")
      ->check(CLI::Range(1L, 64L));
  p->add_flag("--json", json,
              "print one JSON object {section: figures} on stdout (skin, solver or fanout\n"
              "alone: one object per row and line)");
  if (auto exit_code = p.parse(argv)) return exit_code;
  opt.fanout_point = subs->count() > 0 || avs->count() > 0;
  opt.json_lines = (only == "fanout" || only == "skin" || only == "solver") && json;
  return std::nullopt;
}

int bench(const std::vector<std::string>& argv) {
  cli::Parser p("bench", kAbout);
  BenchOptions opt;
  std::string only;
  bool json = false;
  if (auto exit_code = parse(p, argv, opt, only, json)) return *exit_code;
  nlohmann::json all;
  for (const auto& s : kSections) {
    if (!only.empty() && only != s.name) continue;
    std::fprintf(stderr, "== %s\n", s.name);
    auto r = s.run(opt);
    if (!r) return p.failure(std::string(s.name) + ": " + r.error().what());
    all[s.name] = *r;
  }
  if (json && !opt.json_lines) std::printf("%s\n", all.dump().c_str());
  return 0;
}

}  // namespace

MIMIC_COMMAND(bench, "bench", "measure latency, throughput and sizes on this machine", bench);

}  // namespace mimic::app::cmd_bench
