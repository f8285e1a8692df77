// `mimic bench --section web` (bench_web.h): the browser viewer's deform, bytes and latency,
// measured against a `mimic run --http` child of this program on loopback.
#include "bench_web.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "headless_chromium.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/net/client.h"
#include "mimic/net/web_server.h"

namespace mimic::app::bench_web {
namespace {

using Clock = std::chrono::steady_clock;

// `mimic run` of this very program (one sim:walk avatar, the scene and the page on loopback
// ports of its choosing), stopped with SIGINT as a user would, then killed if it lingers.
class RunChild {
 public:
  // `mesh_lod`: the LOD its server deforms and offers as mesh frames (one per run).
  explicit RunChild(int mesh_lod) {
    int out[2];
    if (::pipe(out) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
    posix_spawn_file_actions_addclose(&fa, out[0]);  // the run must not hold its own pipe's read end
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    std::vector<std::string> args = {"/proc/self/exe", "run",      "--quiet",    "--listen",
                                     "127.0.0.1:0",    "--no-udp", "--http",     "127.0.0.1:0",
                                     "--source",       "sim:walk", "--mesh-lod", std::to_string(mesh_lod)};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ok_ = posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    ::close(out[1]);
    out_ = out[0];
  }
  ~RunChild() {
    if (ok_) {
      ::kill(pid_, SIGINT);
      const auto end = Clock::now() + std::chrono::seconds(5);
      while (::waitpid(pid_, nullptr, WNOHANG) == 0) {
        if (Clock::now() > end) {
          ::kill(pid_, SIGKILL);
          ::waitpid(pid_, nullptr, 0);
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    if (out_ >= 0) ::close(out_);
  }
  RunChild(const RunChild&) = delete;
  RunChild& operator=(const RunChild&) = delete;

  // Its first line: "serving on HOST:PORT; browser viewer on http://HOST:PORT/" (empty if none
  // came within `timeout_s`).
  std::string first_line(double timeout_s) {
    const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
    std::string line;
    while (ok_ && Clock::now() < end) {
      pollfd p{out_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char c;
      if (::read(out_, &c, 1) != 1) break;
      if (c == '\n') return line;
      line.push_back(c);
    }
    return "";
  }

 private:
  pid_t pid_ = -1;
  bool ok_ = false;
  int out_ = -1;
};

// "serving on A; browser viewer on B" -> A, B.
std::pair<std::string, std::string> endpoints(const std::string& line) {
  const std::string serving = "serving on ", viewer = "browser viewer on ";
  const size_t semi = line.find(';');
  const size_t at = line.find(viewer);
  if (line.rfind(serving, 0) != 0 || semi == std::string::npos || at == std::string::npos) return {};
  return {line.substr(serving.size(), semi - serving.size()), line.substr(at + viewer.size())};
}

// Why the page cannot run here (empty: it can).
std::string page_skip_reason() {
  if (chromium_path().empty()) return "no Chromium (Debian's chromium; scripts/setup.sh installs it)";
  const auto wasm = std::filesystem::path(net::default_web_root("/proc/self/exe")) / "mimic_web.wasm";
  if (!std::filesystem::exists(wasm))
    return "no WebAssembly skin at " + wasm.string() + " (built only where Emscripten's emcmake is installed)";
  return "";
}

// The page in headless Chromium: its deform bench (?bench=1: per LOD, the median of nine batches
// of 50 frames in the WebAssembly module, microseconds a frame), then `seconds` of drawing: the
// end-to-end latency of the poses it drew and the bytes its WebSocket brought (the window longer
// when the page drew too few poses in it).
nlohmann::json page_figures(const std::string& url, double seconds) {
  if (auto why = page_skip_reason(); !why.empty()) return {{"skipped", why}};
  HeadlessChromium browser;
  if (!browser.ok() || !browser.open(url + "?bench=1")) return {{"skipped", "Chromium did not start or answer"}};
  const std::string version = browser.version();
  auto done = [](const nlohmann::json& r) {
    return !r.value("error", nlohmann::json()).is_null() ||
           (r.contains("bench") && r["bench"]["deform_us"].size() == size_t(avatar::kSkinLodCount));
  };
  nlohmann::json r = browser.wait_report(done, 120);
  if (!r.is_object() || !done(r)) return {{"skipped", "the page did not report its deform bench within 120 s"}};
  if (!r["error"].is_null()) return {{"skipped", "the page: " + r["error"].get<std::string>()}};
  // The deform bench stalled the page for a moment: the latency window starts after it.
  browser.eval("latency.n = 0, latency.drawn.clear()");
  const std::string counters = "[M._mw_counter(1), M._mw_counter(10), M._mw_avatar_count()]";
  const nlohmann::json before = browser.eval(counters);
  const auto t0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  // A loaded machine's software WebGL may draw only a few frames a second: the window stretches
  // (up to six times) until the percentiles rest on enough poses.
  constexpr int kMinPoses = 30;
  while (Clock::now() - t0 < std::chrono::duration<double>(6 * seconds)) {
    const nlohmann::json n = browser.eval("latency.n");
    if (!n.is_number() || n.get<int>() >= kMinPoses) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  const nlohmann::json latency = browser.eval("latencySummary()");
  const nlohmann::json after = browser.eval(counters);
  const double dt_s = std::chrono::duration<double>(Clock::now() - t0).count();
  nlohmann::json out = {{"browser", version + " (headless, software WebGL: SwiftShader)"},
                        {"deform_us", r["bench"]["deform_us"]}};
  if (!latency.is_object() || !before.is_array() || !after.is_array()) {
    out["latency_skipped"] = "the page drew no pose in the window";
    return out;
  }
  out["latency"] = latency;
  out["latency_seconds"] = dt_s;
  const double frames = after[0].get<double>() - before[0].get<double>();
  const double bytes = after[1].get<double>() - before[1].get<double>();
  const double avatars = std::max(1.0, after[2].get<double>());
  out["websocket"] = {{"bytes_per_s", bytes / dt_s / avatars},
                      {"frames_per_s", frames / dt_s / avatars},
                      {"bytes_per_frame", frames > 0 ? bytes / frames : 0.0}};
  return out;
}

// Subscribers of the scene in each mode, side by side for `seconds` once every one of them has
// its first frames: what each received a second per avatar (the payload the server wrote, as
// read from the socket). The lean one also keeps the body model and the poses for the native
// deform.
struct Received {
  std::string model_bytes, name;
  std::vector<rig::Pose> poses;
};

// `with_poses`: the lean and POSE subscribers too (else only the mesh one, at `mesh_lod`).
Result<nlohmann::json> stream_figures(const std::string& scene, double seconds, int mesh_lod, bool with_poses,
                                      Received& got) {
  struct Mode {
    const char* name;
    bool lean;
    uint8_t mesh_lod;
    std::unique_ptr<net::Client> client;
    net::ClientStats start;
  };
  std::vector<Mode> modes;
  if (with_poses) {
    modes.push_back({"lean", true, net::kNoMesh, nullptr, {}});
    modes.push_back({"pose", false, net::kNoMesh, nullptr, {}});
  }
  static const char* const kMeshNames[] = {"mesh_lod0", "mesh_lod1", "mesh_lod2", "mesh_lod3"};
  static_assert(std::size(kMeshNames) == avatar::kSkinLodCount);
  modes.push_back({kMeshNames[mesh_lod], true, uint8_t(mesh_lod), nullptr, {}});
  for (Mode& m : modes) {
    net::ClientOptions o;
    o.connect = scene;
    o.name = std::string("bench-") + m.name;
    o.lean = m.lean;
    o.mesh_lod = m.mesh_lod;
    auto c = net::Client::connect(o);
    if (!c) return tl::unexpected(c.error());
    m.client = std::move(*c);
  }
  if (with_poses)
    modes[0].client->on_pose = [&](const net::RemoteAvatar& a, uint64_t) {
      if (got.model_bytes.empty()) {
        got.model_bytes = a.model_bytes;
        got.name = a.name;
      }
      if (got.poses.size() < 256) got.poses.push_back(a.pose);
    };
  auto pump = [&](double s) {
    const auto end = Clock::now() + std::chrono::duration<double>(s);
    while (Clock::now() < end)
      for (Mode& m : modes) m.client->run_until(Clock::now() + std::chrono::milliseconds(2));
  };
  // Warm: models and topology in, frames flowing to everyone.
  const auto ready_by = Clock::now() + std::chrono::seconds(20);
  auto ready = [&] {
    for (const Mode& m : modes)
      if ((m.mesh_lod == net::kNoMesh ? m.client->stats().frames : m.client->stats().mesh_frames) <= 10) return false;
    return true;
  };
  while (!ready() && Clock::now() < ready_by) pump(0.05);
  if (!ready()) return fail(Errc::timeout, "the scene's subscribers got no frames within 20 s");
  for (Mode& m : modes) m.start = m.client->stats();
  const auto t0 = Clock::now();
  pump(seconds);
  const double dt_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const double avatars = double(std::max<size_t>(1, modes[0].client->avatars().size()));
  nlohmann::json j;
  for (Mode& m : modes) {
    const net::ClientStats& s = m.client->stats();
    const bool mesh = m.mesh_lod != net::kNoMesh;
    const double frames = double(mesh ? s.mesh_frames - m.start.mesh_frames : s.frames - m.start.frames);
    const double bytes = double(mesh ? s.mesh_bytes - m.start.mesh_bytes : s.frame_bytes - m.start.frame_bytes);
    j[m.name] = {{"bytes_per_s", bytes / dt_s / avatars},
                 {"frames_per_s", frames / dt_s / avatars},
                 {"bytes_per_frame", frames > 0 ? bytes / frames : 0.0},
                 {"all_bytes_per_s", double(s.bytes_in - m.start.bytes_in) / dt_s / avatars}};
  }
  if (with_poses) {
    j["model_bytes"] = got.model_bytes.size();
    j["seconds"] = dt_s;
    j["avatars"] = avatars;
  }
  return j;
}

// The native realtime skin on the body model the server sent and the poses it streamed, timed as
// the page times its module: per LOD the median of nine batches of 50 frames after a warm-up,
// positions and normals (mw_bench_deform's call).
Result<nlohmann::json> native_deform(const Received& got) {
  if (got.poses.empty()) return fail(Errc::not_found, "no poses received for the native deform");
  auto model = avatar::body_model_from_json(got.model_bytes, got.name);
  if (!model) return tl::unexpected(model.error());
  nlohmann::json rows = nlohmann::json::array();
  for (int lod = 0; lod < avatar::kSkinLodCount; ++lod) {
    avatar::RealtimeOptions ro;
    ro.lod = lod;
    auto body = avatar::RealtimeBody::create(*model, ro);
    if (!body) return tl::unexpected(body.error());
    avatar::RealtimeSkin skin(*body);
    std::vector<glm::vec3> positions((*body)->vertex_count()), normals((*body)->vertex_count());
    size_t k = 0;
    auto median = [&](size_t step, bool with_normals) {
      auto batch = [&](int n) {
        const auto t0 = Clock::now();
        for (int i = 0; i < n; ++i, k += step)
          skin.evaluate(got.poses[k % got.poses.size()], positions,
                        with_normals ? std::span(normals) : std::span<glm::vec3>());
        return std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / n;
      };
      batch(5);
      std::vector<double> batches;
      for (int b = 0; b < 9; ++b) batches.push_back(batch(50));
      std::sort(batches.begin(), batches.end());
      return batches[4];
    };
    rows.push_back({{"lod", lod},
                    {"vertices", positions.size()},
                    {"native_us", median(1, true)},
                    {"native_same_pose_us", median(0, true)},
                    {"native_no_normals_us", median(1, false)}});
  }
  return rows;
}

// The deform table: native and page per LOD, and their ratio.
nlohmann::json deform_table(nlohmann::json native, const nlohmann::json& page) {
  const bool have_page = page.contains("deform_us");
  for (auto& row : native) {
    const size_t lod = row["lod"].get<size_t>();
    if (!have_page || lod >= page["deform_us"].size()) continue;
    const double page_us = page["deform_us"][lod].get<double>();
    row["page_us"] = page_us;
    row["page_over_native"] = page_us / std::max(row["native_us"].get<double>(), 1e-3);
  }
  return native;
}

void print(const nlohmann::json& j) {
  for (const auto& row : j["deform"]) {
    if (row.contains("page_us"))
      std::fprintf(stderr, "web deform LOD %d, %zu vertices: page (WebAssembly) %.1f us, native %.1f us: %.1fx\n",
                   row["lod"].get<int>(), row["vertices"].get<size_t>(), row["page_us"].get<double>(),
                   row["native_us"].get<double>(), row["page_over_native"].get<double>());
    else
      std::fprintf(stderr, "web deform LOD %d, %zu vertices: native %.1f us (page skipped)\n", row["lod"].get<int>(),
                   row["vertices"].get<size_t>(), row["native_us"].get<double>());
  }
  const auto& b = j["bytes_per_avatar"];
  for (const char* m : {"lean", "pose", "mesh_lod0", "mesh_lod1", "mesh_lod2", "mesh_lod3"})
    std::fprintf(stderr, "web bytes per avatar, %s: %.0f B/s (%.1f B a frame, %.1f frames/s)\n", m,
                 b[m]["bytes_per_s"].get<double>(), b[m]["bytes_per_frame"].get<double>(),
                 b[m]["frames_per_s"].get<double>());
  const auto& p = j["page"];
  if (p.contains("skipped")) std::fprintf(stderr, "web page: skipped: %s\n", p["skipped"].get<std::string>().c_str());
  if (p.contains("websocket"))
    std::fprintf(stderr, "web page's WebSocket: %.0f B/s per avatar (%.1f B a frame)\n",
                 p["websocket"]["bytes_per_s"].get<double>(), p["websocket"]["bytes_per_frame"].get<double>());
  if (p.contains("latency"))
    std::fprintf(stderr,
                 "web end to end (capture -> the page's deform and draw calls submitted): p50 %.1f ms, p99 %.1f ms "
                 "(%d poses drawn)\n",
                 p["latency"]["p50_ms"].get<double>(), p["latency"]["p99_ms"].get<double>(),
                 p["latency"]["poses"].get<int>());
}

}  // namespace

Result<nlohmann::json> run(bool quick) {
  const double seconds = quick ? 2.0 : 5.0;
  nlohmann::json j;
  Received got;
  {
    RunChild run(0);
    const auto [scene, url] = endpoints(run.first_line(30));
    if (scene.empty() || url.empty()) return fail(Errc::timeout, "mimic run --http did not start within 30 s");
    // The browser first, alone with the server: its latency is not the other subscribers' load.
    j["page"] = page_figures(url, seconds);
    auto streams = stream_figures(scene, seconds, 0, true, got);
    if (!streams) return tl::unexpected(streams.error());
    j["bytes_per_avatar"] = *streams;
  }
  // A server deforms and offers one mesh LOD: a run each for the others.
  for (int lod = 1; lod < avatar::kSkinLodCount; ++lod) {
    RunChild run(lod);
    const std::string scene = endpoints(run.first_line(30)).first;
    if (scene.empty()) return fail(Errc::timeout, "mimic run --mesh-lod " + std::to_string(lod) + " did not start");
    Received unused;
    auto streams = stream_figures(scene, seconds, lod, false, unused);
    if (!streams) return tl::unexpected(streams.error());
    j["bytes_per_avatar"].update(*streams);
  }
  auto native = native_deform(got);
  if (!native) return tl::unexpected(native.error());
  j["deform"] = deform_table(*native, j["page"]);
  print(j);
  return j;
}

}  // namespace mimic::app::bench_web
