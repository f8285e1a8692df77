#include "bench_pipeline.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <optional>
#include <thread>
#include <vector>

#include "mimic/core/thread_priority.h"
#include "mimic/devices/source.h"
#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"
#include "mimic/net/server.h"
#include "mimic/net/vmc_encode.h"
#include "mimic/net/vrpn_server.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/tracker_source.h"

namespace mimic::app {

namespace {

using namespace ::mimic::service;

constexpr const char* kWalk = "sim:walk?rate=90&sensors=6";
// The six sensors of layout 6, named as VMC device serials.
constexpr const char* kVmcMap = "map=S0:head,S1:l_hand,S2:r_hand,S3:pelvis,S4:l_foot,S5:r_foot";

// A UDP port nothing holds at the moment (the bench's sender needs it before the source opens).
uint16_t free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  uint16_t port = 0;
  if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0)
    port = ntohs(a.sin_port);
  if (fd >= 0) ::close(fd);
  return port;
}

// Sends the simulated walk's samples as they are made until `stop`; runs on its own thread.
using Sender = std::function<void(const std::atomic<bool>& stop)>;

Result<Sender> vrpn_sender(std::string& spec) {
  auto server = net::VrpnServer::create("127.0.0.1:0");
  if (!server) return tl::unexpected(server.error());
  auto sk = rig::Skeleton::build(rig::default_skeleton_desc());
  if (!sk) return tl::unexpected(sk.error());
  if (auto st = (*server)->add_avatar(*sk); !st) return tl::unexpected(st.error());
  spec = "vrpn:Sensors0@127.0.0.1:" + std::to_string((*server)->port()) + "?layout=6";
  std::shared_ptr<net::VrpnServer> shared(std::move(*server));
  return Sender([shared](const std::atomic<bool>& stop) {
    auto walk = open_tracker_source(*devices::parse_source_spec(kWalk));
    if (!walk || !(*walk)->start()) return;
    std::vector<devices::SensorSample> samples(64);
    while (!stop) {
      shared->poll();
      const size_t n = (*walk)->poll(samples);
      const double unix_s = double(net::wall_clock_us()) * 1e-6;
      for (size_t i = 0; i < n; ++i)
        shared->send_sample(0, samples[i].sensor, samples[i].position_m, samples[i].orientation, unix_s);
      if (n > 0) shared->flush();
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  });
}

Result<Sender> vmc_sender(std::string& spec) {
  const uint16_t port = free_udp_port();
  if (port == 0) return fail(Errc::io_error, "no free UDP port on 127.0.0.1");
  spec = "vmc:127.0.0.1:" + std::to_string(port) + "?" + kVmcMap;
  return Sender([port](const std::atomic<bool>& stop) {
    auto walk = open_tracker_source(*devices::parse_source_spec(kWalk));
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (!walk || !(*walk)->start() || fd < 0) return;
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    std::vector<devices::SensorSample> samples(64);
    std::vector<uint8_t> bundle;
    bundle.reserve(256);
    const char* serials[] = {"S0", "S1", "S2", "S3", "S4", "S5"};
    while (!stop) {
      const size_t n = (*walk)->poll(samples);
      for (size_t i = 0; i < n; ++i) {
        const devices::SensorSample& s = samples[i];
        if (s.sensor >= 6) continue;
        // Unity's left-handed frame: x mirrored, rotations (x, −y, −z, w).
        bundle.clear();
        net::OscWriter w(bundle);
        w.begin_bundle();
        w.begin_message("/VMC/Ext/Tra/Pos", "sfffffff");
        w.arg_string(serials[s.sensor]);
        for (float v : {-s.position_m.x, s.position_m.y, s.position_m.z, s.orientation.x, -s.orientation.y,
                        -s.orientation.z, s.orientation.w})
          w.arg_float(v);
        w.end_message();
        (void)::sendto(fd, bundle.data(), bundle.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
      }
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    ::close(fd);
  });
}

}  // namespace

Result<nlohmann::json> pipeline_latency(const std::string& input, double seconds, int slice_us, int rt_priority) {
  std::string spec = kWalk;
  Sender sender;
  if (input == "vrpn" || input == "vmc") {
    auto s = input == "vrpn" ? vrpn_sender(spec) : vmc_sender(spec);
    if (!s) return tl::unexpected(s.error());
    sender = std::move(*s);
  }
  std::atomic<bool> stop{false};
  std::thread sending;
  if (sender) sending = std::thread([&] { sender(stop); });
  struct Joiner {
    std::atomic<bool>& stop;
    std::thread& t;
    ~Joiner() {
      stop = true;
      if (t.joinable()) t.join();
    }
  } join_sender{stop, sending};

  auto server = net::Server::create({});
  if (!server) return tl::unexpected(server.error());
  auto feed = open_feed(spec);
  if (!feed) return tl::unexpected(feed.error());
  auto body = load_body("");
  if (!body) return tl::unexpected(body.error());
  auto skin = make_skin_deformer(body->model, (*feed)->skeleton(), 2);
  if (!skin) return tl::unexpected(skin.error());
  SinkList sinks;
  sinks.push_back(make_server_sink(**server));
  Pipeline pipeline(std::move(sinks));
  if (auto st = pipeline.add_avatar("bench", std::move(*feed), std::move(body->bytes), std::move(*skin)); !st)
    return tl::unexpected(st.error());
  std::atomic<bool> stop_viewer{false};
  const std::string ep = (*server)->endpoint();
  std::thread viewer([&] {
    net::ClientOptions co;
    co.connect = ep;
    auto c = net::Client::connect(co);
    while (c && !stop_viewer) (void)(*c)->run_until(std::chrono::steady_clock::now() + std::chrono::milliseconds(20));
  });
  using C = std::chrono::steady_clock;
  const bool rt = rt_priority > 0 && set_thread_fifo(rt_priority);
  if (rt_priority > 0 && !rt) {
    stop_viewer = true;
    viewer.join();
    return nlohmann::json{{"refused", true}};
  }
  // As mimic run --realtime: the CPUs out of deep idle states while the loop runs (refused
  // without root, as there: the figure is then the plain SCHED_FIFO one).
  std::optional<CpuWakeupLatency> wakeup;
  if (rt) wakeup.emplace(0);
  // The network sources need their first samples (and VRPN its handshake) before the clock runs.
  const auto warm = C::now() + std::chrono::seconds(5);
  while (pipeline.frames() < 20 && C::now() < warm) {
    pipeline.tick();
    (void)pipeline.service_network(slice_us);
  }
  for (int k = 0; k < kStageCount; ++k) pipeline.timer(k).clear();
  const auto end = C::now() + std::chrono::duration<double>(seconds);
  while (C::now() < end) {
    pipeline.tick();
    (void)pipeline.service_network(slice_us);
  }
  if (rt) set_thread_fifo(0);
  wakeup.reset();
  stop_viewer = true;
  viewer.join();
  const auto s = pipeline.timer(kStageLatency).summary();
  nlohmann::json stages;
  for (int k = 0; k < kStageCount; ++k) {
    const auto ks = pipeline.timer(k).summary();
    stages[stage_name(k)] = {{"p50_us", ks.p50_us}, {"p99_us", ks.p99_us}};
  }
  const char* what = input == "vrpn" ? "VRPN report read" : input == "vmc" ? "VMC bundle read" : "sensor record";
  std::fprintf(stderr, "%s -> frame leaving the socket (%s): p50 %.0f us, p99 %.0f us (%llu frames)\n", what,
               rt ? "mimic run --realtime 50" : "mimic run loop", s.p50_us, s.p99_us,
               static_cast<unsigned long long>(s.count));
  return nlohmann::json{{"p50", s.p50_us}, {"p99", s.p99_us}, {"frames", s.count}, {"stages", stages}};
}

}  // namespace mimic::app
