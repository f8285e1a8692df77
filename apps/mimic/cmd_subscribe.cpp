// mimic subscribe: joins a scene as a viewer and prints what arrives.
#include <algorithm>
#include <map>
#include <chrono>
#include <cstdio>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "command.h"
#include "scene_connect.h"
#include "mimic/core/percentile.h"
#include "mimic/net/client.h"
#include "mimic/net/server.h"

namespace mimic::app::cmd_subscribe {
namespace {

constexpr const char* kAbout =
    "Joins the scene served by 'mimic run' as a subscriber: receives every avatar's body model\n"
    "once, then its pose frames (latest wins). Prints one line per model and per frame, or with\n"
    "--json only a summary object at the end:\n"
    "  frames, avatars, fps, latency_ms_p50, latency_ms_p99, lost, out_of_order, model_bytes,\n"
    "  frame_bytes_mean, mesh_frames, reconnects, duration_s, transport, udp_frames, lean_keys,\n"
    "  lean, lean_shift, lean_unreferenced, key_requests, cuts, stall_resyncs, outages, outage_s,\n"
    "  outage_max_s, lost_across_sessions\n"
    "Latency is the frame's capture time (sender's clock) to its arrival here; fps is per avatar,\n"
    "the rate its frames were captured at (their timestamps), not how fast they happened to arrive.\n"
    "After any cut (the server restarted, dropped this viewer, or timed it out while this\n"
    "process was stopped) it reconnects and goes on; a line on stderr says so, and another how\n"
    "long frames were missing when they come again. lost counts frames missed by sequence, also\n"
    "across a server restart when the same publisher goes on (outage_s: the time without\n"
    "frames). A viewer that was not running for over a second drops what its sockets buffered\n"
    "meanwhile and resumes with the newest frames.\n"
    "Names and server messages are printed with control, bidi and invisible characters escaped\n"
    "(\\uXXXX; bytes that are not UTF-8 as \\xNN).";

// The --json summary of a run (the keys the usage lists); reorders `latency_ms`.
nlohmann::json summary(const net::Client& client, uint64_t frames, double fps, std::vector<double>& latency_ms,
                       double duration_s) {
  const auto& s = client.stats();
  nlohmann::json j;
  j["frames"] = frames;
  j["avatars"] = client.avatars().size();
  j["fps"] = fps;
  j["latency_ms_p50"] = percentile_in_place(latency_ms, 0.50);
  j["latency_ms_p99"] = percentile_in_place(latency_ms, 0.99);
  j["lost"] = s.lost;
  j["out_of_order"] = s.out_of_order;
  j["model_bytes"] = s.model_bytes;
  j["models"] = s.models;
  j["frame_bytes_mean"] = s.frames ? double(s.frame_bytes) / double(s.frames) : 0.0;
  j["mesh_frames"] = s.mesh_frames;
  j["reconnects"] = s.reconnects;
  j["duration_s"] = duration_s;
  j["transport"] = s.udp_frames > 0 ? "udp" : "tcp";
  j["udp_frames"] = s.udp_frames;
  j["lean"] = (client.negotiated_capabilities() & net::kCapLeanPose) != 0;
  // The precision the server streams at (its key frames carry it); null before any key.
  j["lean_shift"] = nullptr;
  for (const auto& [id, m] : client.avatars())
    if (m.lean.valid) j["lean_shift"] = m.lean.shift;
  j["lean_keys"] = s.lean_keys;
  j["lean_unreferenced"] = s.lean_unreferenced;
  j["key_requests"] = s.key_requests;
  j["cuts"] = s.cuts;
  j["stall_resyncs"] = s.stall_resyncs;
  j["outages"] = s.outages;
  j["outage_s"] = s.outage_s;
  j["outage_max_s"] = s.outage_max_s;
  j["lost_across_sessions"] = s.lost_across_sessions;
  return j;
}

struct Options {
  net::ClientOptions client;
  long count = 0;
  int lod = -1;
  double duration_s = 0;
  bool json = false;
};

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  o.client.connect = "127.0.0.1:7777";
  bool lean = false, no_lean = false;
  p->add_option("--connect", o.client.connect,
                "the scene, or a scene on a NATS broker:\n"
                "nats://HOST:PORT[,nats://HOST:PORT...][/SCENE] (credentials from\n"
                "MIMIC_NATS_USER + MIMIC_NATS_PASSWORD, or MIMIC_NATS_TOKEN)")
      ->type_name("HOST:PORT");
  p->add_option("--count", o.count, "stop after N pose frames (0: no limit)")->check(CLI::NonNegativeNumber);
  p->add_option("--duration", o.duration_s, "stop after S seconds (default: until --count, or forever)")
      ->default_str("")
      ->check(cli::finite_range(0, INFINITY));
  p->add_option("--mesh-lod", o.lod, "also receive mesh frames at LOD L (0 = finest)")
      ->default_str("")
      ->check(CLI::Range(0, 7));
  p->add_flag("--udp", o.client.udp,
              "pose frames as UDP datagrams (models stay on TCP; frames come over\n"
              "TCP until the server has registered this address, or if it offers\n"
              "no UDP)");
  auto* lean_flag = p->add_flag("--lean", lean, "the lean pose stream (the default)");
  p->add_flag("--no-lean", no_lean,
              "POSE frames (150 bytes, angles in pi/32767 rad steps) instead of the\n"
              "lean pose stream taken by default: key and delta frames of about 60\n"
              "bytes at the server's precision (mimic run --lean-shift;\n"
              "docs/protocol.md)")
      ->excludes(lean_flag);
  p->add_flag("--json", o.json, "print only the JSON summary");
  if (auto exit_code = p.parse(argv)) return exit_code;
  o.client.lean = !no_lean;
  o.client.role = net::Role::subscriber;
  o.client.name = "mimic subscribe";
  if (o.lod >= 0) o.client.mesh_lod = static_cast<uint8_t>(o.lod);
  return std::nullopt;
}

int subscribe(const std::vector<std::string>& argv) {
  cli::Parser p("subscribe", kAbout);
  Options opts;
  if (auto exit_code = parse(p, argv, opts)) return *exit_code;
  const long count = opts.count;
  const double duration_s = opts.duration_s;
  const bool json = opts.json;
  const net::ClientOptions& o = opts.client;
  auto c = connect_scene(o);
  if (!c) return failure("subscribe", net::printable(c.error().what()));
  net::Client& client = **c;
  if (o.udp && !(client.negotiated_capabilities() & net::kCapUdpPose))
    std::fprintf(stderr, "subscribe: the server offers no UDP; pose frames come over TCP\n");

  using C = std::chrono::steady_clock;
  std::vector<double> latency_ms;
  latency_ms.reserve(1 << 16);
  uint64_t frames = 0;
  // Per avatar: frames and the capture times (sender's clock) of the first and the last.
  struct Rate {
    uint64_t frames = 0, first_us = 0, last_us = 0;
  };
  std::map<uint16_t, Rate> rates;
  client.on_model = [&](const net::RemoteAvatar& m) {
    if (!json)
      // Names come from other peers: escaped, they cannot drive this terminal.
      std::printf("model avatar=%u name=%s dofs=%u revision=%u bytes=%zu\n", m.id, net::printable(m.name).c_str(),
                  m.dof_count, m.revision, m.model_bytes.size());
  };
  // Cuts and comebacks, as they happen (the client reconnects by itself).
  client.on_cut = [&](const std::string& why) {
    std::fprintf(stderr, "subscribe: connection cut (%s); reconnecting\n", why.c_str());
  };
  // (The frames it cost are counted as each avatar's first frame comes: lost in the summary.)
  client.on_back = [&](double outage_s, uint64_t) {
    std::fprintf(stderr, "subscribe: frames again after %.2f s without\n", outage_s);
  };
  client.on_removed = [&](uint16_t id) {
    if (!json) std::printf("removed avatar=%u\n", id);
  };
  client.on_pose = [&](const net::RemoteAvatar& m, uint64_t now_us) {
    // Several frames come in one read (every avatar of a tick): the ones past the count are not
    // this run's.
    if (count > 0 && frames >= uint64_t(count)) return;
    const double lat = (double(now_us) - double(m.last.time_us)) * 1e-3;
    latency_ms.push_back(lat);
    frames++;
    Rate& r = rates[m.id];
    if (r.frames++ == 0) r.first_us = m.last.time_us;
    r.last_us = m.last.time_us;
    if (!json)
      std::printf("pose avatar=%u seq=%u latency_ms=%.3f root=(%.3f %.3f %.3f)%s\n", m.id, m.last.sequence, lat,
                  m.pose.root_position_m.x, m.pose.root_position_m.y, m.pose.root_position_m.z,
                  (m.last.flags & net::kPoseStale) ? " stale" : "");
  };
  const auto start = C::now();
  Status st;
  while (count == 0 || frames < uint64_t(count)) {
    const auto now = C::now();
    if (duration_s > 0 && now - start >= std::chrono::duration<double>(duration_s)) break;
    st = client.run_until(now + std::chrono::milliseconds(5));
    if (!st) break;
  }
  // Frames per second per avatar, at the rate they were captured (their timestamps), averaged
  // over the avatars: frames that arrive in a burst (the latest pose of every avatar on joining,
  // a backlog after a stall) do not make the source look faster than it is.
  double fps = 0;
  size_t timed = 0;
  for (const auto& [id, r] : rates) {
    if (r.frames < 2 || r.last_us <= r.first_us) continue;
    fps += double(r.frames - 1) / (double(r.last_us - r.first_us) * 1e-6);
    timed++;
  }
  if (timed > 0) fps /= double(timed);
  if (json) {
    const double duration = std::chrono::duration<double>(C::now() - start).count();
    std::printf("%s\n", summary(client, frames, fps, latency_ms, duration).dump().c_str());
  }
  client.close();
  if (!st) return failure("subscribe", net::printable(st.error().what()));
  return 0;
}

}  // namespace

MIMIC_COMMAND(subscribe, "subscribe", "join a scene as a viewer and print or summarise what arrives", subscribe);

}  // namespace mimic::app::cmd_subscribe
