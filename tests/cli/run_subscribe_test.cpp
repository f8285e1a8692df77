// End to end over loopback: `mimic run` serves, `mimic subscribe` (and a second `mimic run
// --publish`) join; Ctrl-C stops the service cleanly.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <memory>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "mimic/net/frame_codec.h"
#include "mimic_proc.h"
#include "replay_csv.h"
#include "test_data.h"

extern char** environ;

namespace run_subscribe_test {

namespace {

using mimic::test::endpoint_of;
using mimic::test::Proc;

nlohmann::json last_json(const std::string& out) {
  const auto start = out.rfind("\n{");
  const std::string text = start == std::string::npos ? out : out.substr(start + 1);
  return nlohmann::json::parse(text, nullptr, false);
}

TEST(RunSubscribe, SubscriberGetsModelAndFramesFromMimicRun) {
  Proc run({"run", "--listen", "127.0.0.1:0", "--duration", "8", "--quiet", "--json"});
  ASSERT_TRUE(run.ok());
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  Proc sub({"subscribe", "--connect", ep, "--count", "90", "--json"});
  ASSERT_EQ(sub.wait(15.0), 0) << sub.err();
  const auto j = last_json(sub.out());
  ASSERT_FALSE(j.is_discarded()) << sub.out();
  for (const char* k :
       {"frames", "avatars", "fps", "latency_ms_p50", "latency_ms_p99", "lost", "model_bytes", "frame_bytes_mean"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["frames"], 90);
  EXPECT_EQ(j["avatars"], 1);
  EXPECT_EQ(j["lost"], 0);
  EXPECT_GT(j["model_bytes"].get<double>(), 100.0);
  EXPECT_LE(j["frame_bytes_mean"].get<double>(), 200.0);
  EXPECT_GT(j["fps"].get<double>(), 30.0);  // the default source runs at 90 Hz
  EXPECT_GE(j["latency_ms_p50"].get<double>(), 0.0);
  // Stage timings on request, while running.
  run.signal(SIGUSR1);
  EXPECT_EQ(run.wait(0.5), -1);  // still running
  run.signal(SIGINT);
  EXPECT_EQ(run.wait(10.0), 0) << run.err();
  EXPECT_NE(run.err().find("stopped after"), std::string::npos);
  size_t json_lines = 0;
  for (size_t p = run.out().find("\n{"); p != std::string::npos; p = run.out().find("\n{", p + 1)) json_lines++;
  EXPECT_EQ(json_lines, 2u) << run.out();  // one on SIGUSR1, one at exit
  const auto r = last_json(run.out());
  ASSERT_FALSE(r.is_discarded()) << run.out();
  EXPECT_GT(r["frames"].get<int>(), 0);
  EXPECT_EQ(r["server"]["frames_dropped"], 0);
  // The limits and what they did, for whoever watches the service.
  for (const char* k : {"sessions_open", "sessions_timed_out", "sessions_refused_per_address", "sessions_closed_slow",
                        "model_bytes_held", "udp_challenges", "udp_wrong_address", "udp_expired"})
    EXPECT_TRUE(r["server"].contains(k)) << k;
  EXPECT_GT(r["server"]["model_bytes_held"].get<double>(), 100.0);  // the avatar's one model packet
  EXPECT_EQ(r["silent_sources"], 0);
  // The realtime loop allocated nothing per frame, although a subscriber joined and left.
  EXPECT_EQ(r["loop_allocations"], 0);
  EXPECT_EQ(r["send_failures"], 0);
  for (const char* s : {"read", "solve", "deform", "encode", "send", "latency"})
    EXPECT_TRUE(r["stages"].contains(s)) << s;
}

TEST(RunSubscribe, SubscriberTakesPoseFramesAsDatagrams) {
  Proc run({"run", "--listen", "127.0.0.1:0", "--duration", "8", "--quiet", "--json"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  Proc sub({"subscribe", "--connect", ep, "--udp", "--count", "90", "--json"});
  ASSERT_EQ(sub.wait(15.0), 0) << sub.err();
  const auto j = last_json(sub.out());
  ASSERT_FALSE(j.is_discarded()) << sub.out();
  EXPECT_EQ(j["frames"], 90);
  EXPECT_EQ(j["transport"], "udp");
  // The first frames may come on the stream while the address is being registered.
  EXPECT_GE(j["udp_frames"].get<int>(), 80);
  EXPECT_EQ(j["lost"], 0);
  EXPECT_LE(j["frame_bytes_mean"].get<double>(), 200.0);
  run.signal(SIGINT);
  EXPECT_EQ(run.wait(10.0), 0) << run.err();
  const auto r = last_json(run.out());
  ASSERT_FALSE(r.is_discarded()) << run.out();
  EXPECT_EQ(r["loop_allocations"], 0);
  EXPECT_EQ(r["server"]["udp"], true);
  EXPECT_EQ(r["server"]["udp_registered"], 1);
  EXPECT_GE(r["server"]["udp_frames_out"].get<int>(), 80);
}

// Two avatars' frames of a tick arrive in one read: --count stops at the count, not at the end
// of the read (an odd count would otherwise always come out one over).
TEST(RunSubscribe, CountStopsAtTheCountWhenFramesArriveTogether) {
  Proc run({"run", "--listen", "127.0.0.1:0", "--source", "sim:walk", "--source", "sim:idle?seed=2", "--duration", "8",
            "--quiet"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  for (const char* count : {"31", "45"}) {
    Proc sub({"subscribe", "--connect", ep, "--count", count, "--json"});
    ASSERT_EQ(sub.wait(15.0), 0) << sub.err();
    const auto j = last_json(sub.out());
    ASSERT_FALSE(j.is_discarded()) << sub.out();
    EXPECT_EQ(j["frames"], std::stoi(count));
    EXPECT_EQ(j["avatars"], 2);
  }
}

TEST(RunSubscribe, WithoutUdpTheSubscriberIsToldAndFramesComeOnTheStream) {
  Proc run({"run", "--listen", "127.0.0.1:0", "--no-udp", "--duration", "8", "--quiet", "--json"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  Proc sub({"subscribe", "--connect", ep, "--udp", "--count", "30", "--json"});
  ASSERT_EQ(sub.wait(15.0), 0) << sub.err();
  EXPECT_NE(sub.err().find("offers no UDP"), std::string::npos) << sub.err();
  const auto j = last_json(sub.out());
  ASSERT_FALSE(j.is_discarded()) << sub.out();
  EXPECT_EQ(j["frames"], 30);
  EXPECT_EQ(j["transport"], "tcp");
  EXPECT_EQ(j["udp_frames"], 0);
  run.signal(SIGINT);
  EXPECT_EQ(run.wait(10.0), 0) << run.err();
  const auto r = last_json(run.out());
  ASSERT_FALSE(r.is_discarded()) << run.out();
  EXPECT_EQ(r["server"]["udp"], false);
}

TEST(RunSubscribe, SeveralAvatarsAndARemotePublisher) {
  Proc host({"run", "--listen", "127.0.0.1:0", "--source", "sim:walk", "--source", "sim:idle?seed=2", "--duration",
             "12", "--quiet"});
  const std::string ep = endpoint_of(host);
  ASSERT_FALSE(ep.empty()) << host.err();
  Proc guest({"run", "--publish", ep, "--source", "sim:walk?seed=3", "--duration", "10", "--quiet"});
  const std::string guest_line = guest.first_line(10.0);
  ASSERT_EQ(guest_line, "publishing into " + ep) << guest.err();
  Proc sub({"subscribe", "--connect", ep, "--count", "300", "--json"});
  ASSERT_EQ(sub.wait(15.0), 0) << sub.err();
  const auto j = last_json(sub.out());
  ASSERT_FALSE(j.is_discarded()) << sub.out();
  EXPECT_EQ(j["avatars"], 3);  // two hosted, one published from the second process
  EXPECT_EQ(j["models"], 3);
  EXPECT_EQ(j["lost"], 0);
  // fps is per avatar and by capture time: the sources' rate, whatever the arrival pattern.
  EXPECT_GT(j["fps"].get<double>(), 20.0);
  EXPECT_LT(j["fps"].get<double>(), 200.0);
  // A subscriber that stops after the burst on joining (the latest pose of every avatar, all
  // at once) does not report millions of frames per second.
  Proc burst({"subscribe", "--connect", ep, "--count", "3", "--json"});
  ASSERT_EQ(burst.wait(15.0), 0) << burst.err();
  const auto b = last_json(burst.out());
  ASSERT_FALSE(b.is_discarded()) << burst.out();
  EXPECT_LT(b["fps"].get<double>(), 200.0) << burst.out();
}

TEST(RunSubscribe, RefusesToExposeTheSceneWithoutASecret) {
  Proc run({"run", "--listen", "0.0.0.0:0", "--duration", "1"});
  EXPECT_EQ(run.wait(10.0), 1);
  EXPECT_NE(run.err().find("secret"), std::string::npos) << run.err();
}

// While the tracker is gone (a replayed log that has ended), `mimic run` keeps sending the last
// pose flagged stale at a lower rate (10 Hz), and says so in its JSON.
TEST(RunSubscribe, AnOutageSendsTheLastPoseFlaggedStale) {
  const std::string log = "/tmp/mimic_outage_" + std::to_string(::getpid()) + ".mlog";
  Proc rec({"record", "--source", "sim:idle?sensors=6", "--duration", "0.5", "--out", log, "--quiet"});
  ASSERT_EQ(rec.wait(20.0), 0) << rec.err();
  const auto cycles = mimic::test::cycle_times(mimic::test::replay_csv(log));
  ASSERT_GE(cycles.size(), 40u);
  Proc run({"run", "--source", "replay:" + log, "--listen", "127.0.0.1:0", "--duration", "3", "--quiet", "--json"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  Proc sub({"subscribe", "--connect", ep, "--duration", "2.5"});
  EXPECT_EQ(sub.wait(15.0), 0) << sub.err();
  size_t stale = 0, fresh = 0;
  for (size_t p = sub.out().find("pose "); p != std::string::npos; p = sub.out().find("pose ", p + 1)) {
    const size_t end = sub.out().find('\n', p);
    const std::string line = sub.out().substr(p, end - p);
    (line.find(" stale") != std::string::npos ? stale : fresh)++;
  }
  EXPECT_GE(stale, 10u) << sub.out();
  EXPECT_LE(stale, 30u);  // about 10 Hz over the 2 s after the log ended, not the source's 100 Hz
  ASSERT_EQ(run.wait(10.0), 0) << run.err();
  const auto r = last_json(run.out());
  ASSERT_FALSE(r.is_discarded()) << run.out();
  EXPECT_EQ(r["silent_sources"], 1);
  EXPECT_GE(r["stale_frames"].get<int>(), 15);
  EXPECT_LE(r["stale_frames"].get<int>(), 32);
  EXPECT_LE(r["frames"].get<size_t>(), cycles.size());  // one frame per cycle, not per sample
  std::remove(log.c_str());
}

// Four birds in group mode deliver one record per bird per measurement cycle; `mimic run` solves
// and sends one frame per cycle, not one per record.
TEST(RunSubscribe, GroupModeBirdsMakeOneFramePerCycle) {
  Proc sim({"sim", "flock", "--birds", "4", "--seed", "3", "--busy", "0.05"});
  const std::string pty = sim.first_line(10.0);
  ASSERT_EQ(pty.rfind("/dev/", 0), 0u) << pty << sim.err();
  Proc run({"run", "--source", "flock:" + pty + "?birds=4", "--listen", "127.0.0.1:0", "--duration", "3", "--quiet",
            "--json"});
  ASSERT_EQ(run.wait(20.0), 0) << run.err();
  sim.signal(SIGINT);
  ASSERT_EQ(sim.wait(10.0), 0) << sim.err();
  const auto r = last_json(run.out());
  ASSERT_FALSE(r.is_discarded()) << run.out() << run.err();
  // The device counts the records it sent (four a cycle, about 100 cycles a second when the
  // machine is idle). One frame per record would be four times the cycles; a busy machine may
  // fold two cycles into one frame, never split one.
  const std::string& said = sim.err();
  const size_t at = said.rfind(" records, ");
  ASSERT_NE(at, std::string::npos) << said;
  const size_t from = said.find_last_not_of("0123456789", at - 1) + 1;
  const int records = std::stoi(said.substr(from, at - from));
  const int frames = r["frames"].get<int>();
  EXPECT_GE(frames, 20) << run.out();
  EXPECT_LE(frames, records / 4 + 2) << records << " records; " << run.out();
}

TEST(RunSubscribe, HelpIsComplete) {
  Proc run({"run", "--help"});
  ASSERT_EQ(run.wait(10.0), 0);
  for (const char* opt : {"--source", "--body", "--listen", "--secret", "--publish", "--vmc", "--duration", "--json"})
    EXPECT_NE(run.out().find(opt), std::string::npos) << opt;
  // A secret on the command line is visible to every user: the help says so and names the
  // environment variable to use instead.
  EXPECT_NE(run.out().find("'ps'"), std::string::npos);
  EXPECT_NE(run.out().find("prefer the MIMIC_SECRET"), std::string::npos);
  Proc sub({"subscribe", "--help"});
  ASSERT_EQ(sub.wait(10.0), 0);
  for (const char* opt : {"--connect", "--count", "--json", "latency_ms_p99", "frame_bytes_mean"})
    EXPECT_NE(sub.out().find(opt), std::string::npos) << opt;
}

// mimic subscribe takes the lean stream unless told not to; mimic run's --lean-shift and
// --lean-key-interval set its precision and key frames, as the subscriber sees them.
TEST(RunSubscribe, LeanStreamByDefaultAtThePrecisionAndKeyIntervalMimicRunServes) {
  struct Seen {
    nlohmann::json lean, pose;
  };
  auto watch = [](const std::vector<std::string>& flags) {
    std::vector<std::string> args = {"run", "--listen", "127.0.0.1:0", "--duration", "20", "--quiet"};
    args.insert(args.end(), flags.begin(), flags.end());
    Proc run(args);
    const std::string ep = endpoint_of(run);
    EXPECT_FALSE(ep.empty()) << run.err();
    Proc lean({"subscribe", "--connect", ep, "--count", "360", "--json"});
    Proc pose({"subscribe", "--connect", ep, "--count", "360", "--json", "--no-lean"});
    EXPECT_EQ(lean.wait(30.0), 0) << lean.err();
    EXPECT_EQ(pose.wait(30.0), 0) << pose.err();
    run.signal(SIGINT);
    EXPECT_EQ(run.wait(10.0), 0) << run.err();
    return Seen{last_json(lean.out()), last_json(pose.out())};
  };
  const Seen plain = watch({});
  ASSERT_FALSE(plain.lean.is_discarded() || plain.pose.is_discarded());
  EXPECT_EQ(plain.lean["lean"], true);
  EXPECT_EQ(plain.lean["lean_shift"], 3);
  EXPECT_EQ(plain.lean["lost"], 0);
  // One key on joining, then one every 90 frames: 360 frames hold 4 or 5.
  EXPECT_GE(plain.lean["lean_keys"].get<int>(), 4);
  EXPECT_LE(plain.lean["lean_keys"].get<int>(), 6);
  EXPECT_EQ(plain.pose["lean"], false);
  EXPECT_TRUE(plain.pose["lean_shift"].is_null());
  EXPECT_EQ(plain.pose["lean_keys"], 0);
  EXPECT_EQ(plain.pose["frame_bytes_mean"], 150);
  EXPECT_LT(plain.lean["frame_bytes_mean"].get<double>(), 100.0);  // against 150

  const Seen fine = watch({"--lean-shift", "0", "--lean-key-interval", "10"});
  EXPECT_EQ(fine.lean["lean_shift"], 0);
  EXPECT_GE(fine.lean["lean_keys"].get<int>(), 35);  // 360 / 10, and the first
  EXPECT_LE(fine.lean["lean_keys"].get<int>(), 39);
  const Seen coarse = watch({"--lean-shift", "8", "--lean-key-interval", "0"});
  EXPECT_EQ(coarse.lean["lean_shift"], 8);
  EXPECT_LE(coarse.lean["lean_keys"].get<int>(), 2) << "no periodic keys: the first, and one after a loss at most";
  std::printf(
      "[ figure ] built-in walk, lean stream bytes per avatar-frame: shift 0 with a key every 10: %.1f, "
      "shift 3 (default, key every 90): %.1f, shift 8 without periodic keys: %.1f; POSE: %.0f\n",
      fine.lean["frame_bytes_mean"].get<double>(), plain.lean["frame_bytes_mean"].get<double>(),
      coarse.lean["frame_bytes_mean"].get<double>(), plain.pose["frame_bytes_mean"].get<double>());
  EXPECT_GT(fine.lean["frame_bytes_mean"].get<double>(), plain.lean["frame_bytes_mean"].get<double>());
  EXPECT_LT(coarse.lean["frame_bytes_mean"].get<double>(), plain.lean["frame_bytes_mean"].get<double>());

  // Out of bounds: a usage error naming the flag and its bounds.
  for (const auto& [flag, value, says] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"--lean-shift", "9", "--lean-shift must be 0 to 8"},
           {"--lean-shift", "-1", "--lean-shift must be 0 to 8"},
           {"--lean-key-interval", "3601", "--lean-key-interval must be 0 (no periodic key frames) to 3600"},
           {"--lean-key-interval", "often", "--lean-key-interval expects an integer"}}) {
    Proc bad({"run", "--listen", "127.0.0.1:0", flag, value, "--duration", "1", "--quiet"});
    EXPECT_EQ(bad.wait(10.0), 2) << flag << " " << value;
    EXPECT_NE(bad.err().find(says), std::string::npos) << bad.err();
  }
}

}  // namespace

namespace {

TEST(Bench, NetSectionReportsItsFigures) {
  Proc bench({"bench", "--section", "net", "--quick", "--json"});
  ASSERT_EQ(bench.wait(60.0), 0) << bench.err();
  const auto j = last_json(bench.out());
  ASSERT_FALSE(j.is_discarded()) << bench.out();
  const auto& n = j["net"];
  EXPECT_EQ(n["bytes_per_avatar_frame"]["mimic"], 150);
  EXPECT_GT(n["bytes_per_avatar_frame"]["vmc"].get<int>(), n["bytes_per_avatar_frame"]["raw_float"].get<int>());
  EXPECT_GT(n["bytes_per_avatar_frame"]["raw_float"].get<int>(), 150);
  for (const char* k :
       {"loopback_latency_us", "loopback_latency_udp_us", "record_to_socket_us", "fanout_90hz", "max_streams_kept_up"})
    EXPECT_TRUE(n.contains(k)) << k;
  EXPECT_GT(n["record_to_socket_us"]["frames"].get<int>(), 0);
  // The network trackers' samples reached the avatar's frames: a VRPN report and a VMC bundle
  // read from the socket, each to a frame out.
  for (const char* k : {"vrpn_to_socket_us", "vmc_to_socket_us"}) {
    ASSERT_TRUE(n.contains(k)) << k;
    EXPECT_GT(n[k]["frames"].get<int>(), 10) << k;
    EXPECT_GT(n[k]["p99"].get<double>(), 0) << k;
  }
  // Every fan-out point delivered what it could account for: received + lost = expected.
  for (const auto& f : n["fanout_90hz"])
    EXPECT_EQ(f["received"].get<uint64_t>() + f["lost"].get<uint64_t>(), f["expected"].get<uint64_t>());
}

// One JSON object per configuration and line: direct TCP and UDP, and through a broker (or a
// row saying why the broker rows were skipped).
TEST(Bench, FanoutSectionPrintsOneRowPerTransport) {
  Proc bench({"bench", "--section", "fanout", "--quick", "--json"});
  ASSERT_EQ(bench.wait(120.0), 0) << bench.err();
  std::vector<nlohmann::json> rows;
  size_t at = 0;
  const std::string out = bench.out();
  while (at < out.size()) {
    const size_t end = out.find('\n', at);
    const std::string line = out.substr(at, end == std::string::npos ? std::string::npos : end - at);
    at = end == std::string::npos ? out.size() : end + 1;
    if (line.empty()) continue;
    rows.push_back(nlohmann::json::parse(line, nullptr, false));
    ASSERT_FALSE(rows.back().is_discarded()) << line;
  }
  ASSERT_EQ(rows.size(), 3u) << out;
  const char* transports[] = {"tcp", "udp", "nats"};
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    EXPECT_EQ(r["transport"], transports[i]);
    if (r.contains("skipped")) {
      EXPECT_EQ(r["transport"], "nats");
      EXPECT_FALSE(r["skipped"].get<std::string>().empty());
      continue;
    }
    for (const char* k : {"streams", "avatars", "hz", "tick_us_p50", "tick_us_p99", "bytes_per_avatar_frame",
                          "cpu_percent", "lost", "sender_threads"})
      EXPECT_TRUE(r.contains(k)) << r["transport"] << " " << k;
    EXPECT_EQ(r["streams"].get<uint64_t>(), 100u);
    // Every frame counted once: a broker row's window closes a few ticks after the last publish,
    // and what a loaded machine still had on the way then is counted after it.
    const uint64_t after_window = r.contains("settled_after_window") ? r["settled_after_window"].get<uint64_t>() : 0;
    EXPECT_EQ(r["received"].get<uint64_t>() + r["lost"].get<uint64_t>() + after_window, r["expected"].get<uint64_t>())
        << r.dump();
    EXPECT_LT(r["bytes_per_avatar_frame"].get<double>(), 64.0);
    if (r["transport"] == "nats") {
      EXPECT_GT(r["publish_to_relay_ms_p50"].get<double>(), 0.0);
      EXPECT_GE(r["publish_to_relay_ms_p99"].get<double>(), r["publish_to_relay_ms_p50"].get<double>());
      EXPECT_GE(r["relay_fanouts_per_tick"].get<double>(), 0.5);
    }
  }
}

}  // namespace

namespace {

TEST(RunSubscribe, RunsWithACalibrationFromMimicCalibrate) {
  const std::string cal = ::testing::TempDir() + "run_subscribe_cal.json";
  Proc calibrate({"calibrate", "--source", "sim:idle?sensors=6", "--out", cal, "--countdown", "0", "--seconds", "1",
                  "--max-motion-cm", "10", "--max-motion-deg", "30"});
  ASSERT_EQ(calibrate.wait(30.0), 0) << calibrate.err();
  Proc run(
      {"run", "--listen", "127.0.0.1:0", "--source", "sim:walk", "--calibration", cal, "--duration", "6", "--quiet"});
  const std::string ep = endpoint_of(run);
  ASSERT_FALSE(ep.empty()) << run.err();
  EXPECT_NE(run.err().find("calibration"), std::string::npos);
  Proc sub({"subscribe", "--connect", ep, "--count", "20", "--json"});
  ASSERT_EQ(sub.wait(15.0), 0) << sub.err();
  const auto j = last_json(sub.out());
  ASSERT_FALSE(j.is_discarded()) << sub.out();
  EXPECT_EQ(j["frames"], 20);
  EXPECT_EQ(j["avatars"], 1);

  Proc missing({"run", "--listen", "127.0.0.1:0", "--calibration", "/nonexistent/cal.json", "--duration", "1"});
  EXPECT_EQ(missing.wait(10.0), 1);
  EXPECT_NE(missing.err().find("/nonexistent/cal.json"), std::string::npos) << missing.err();
}

}  // namespace

namespace {

// mimic bench skin / solver: the metaball frame against linear blend skinning of the same
// vertices measured in one run, and the solve time of every layout.
TEST(Bench, SkinAndSolverSectionsReportTheirFigures) {
  Proc bench({"bench", "--section", "skin", "--quick", "--json"});
  ASSERT_EQ(bench.wait(120.0), 0) << bench.err();
  // One JSON object per LOD, one per line, finest first.
  std::vector<nlohmann::json> rows;
  std::istringstream lines(bench.out());
  for (std::string line; std::getline(lines, line);) {
    if (line.empty()) continue;
    rows.push_back(nlohmann::json::parse(line, nullptr, false));
    ASSERT_FALSE(rows.back().is_discarded()) << line;
  }
  ASSERT_EQ(rows.size(), 4u) << bench.out();
  int previous_vertices = 1 << 30;
  for (size_t lod = 0; lod < rows.size(); ++lod) {
    const auto& row = rows[lod];
    EXPECT_EQ(row["lod"], lod);
    for (const char* key : {"full_us", "realtime_us", "realtime_muscles_us", "realtime_contact_us", "lbs_us", "dqs_us",
                            "cor_us", "lbs_ns_per_vertex", "dqs_ns_per_vertex", "cor_ns_per_vertex"})
      EXPECT_GT(row[key].get<double>(), 0.0) << key;
    EXPECT_LT(row["vertices"].get<int>(), previous_vertices) << "LODs coarsen";
    previous_vertices = row["vertices"].get<int>();
    EXPECT_GT(row["triangles"].get<int>(), row["vertices"].get<int>());
    EXPECT_EQ(row["contact_pairs"].get<int>(), 10);
    EXPECT_GT(row["contact_moved_per_frame"].get<double>(), 0.0) << "the walk's legs and arms touch";
  }
  // The solver section alone: one object per layout.
  Proc solver({"bench", "--section", "solver", "--quick", "--json"});
  ASSERT_EQ(solver.wait(120.0), 0) << solver.err();
  std::vector<std::string> layouts;
  std::istringstream solver_lines(solver.out());
  for (std::string line; std::getline(solver_lines, line);) {
    const auto k = nlohmann::json::parse(line, nullptr, false);
    ASSERT_FALSE(k.is_discarded()) << line;
    EXPECT_EQ(k["section"], "solver");
    EXPECT_GT(k["frames"].get<int>(), 10) << line;
    EXPECT_GT(k["p50_us"].get<double>(), 0.0) << line;
    EXPECT_LE(k["p50_us"].get<double>(), k["p99_us"].get<double>()) << line;
    layouts.push_back(k["sensors"].get<std::string>());
  }
  EXPECT_EQ(layouts, (std::vector<std::string>{"3", "6", "11", "all"}));
}

// Neighbouring sensors (pelvis and thighs): the joint centres found while the wearer walks are
// swapped into the running solver, without an allocation in the loop.
TEST(RunSubscribe, RefinesTheCalibrationFromTheMotion) {
  const std::string cal = ::testing::TempDir() + "run_subscribe_cal11.json";
  Proc calibrate({"calibrate", "--source", "sim:idle?sensors=11", "--out", cal, "--countdown", "0", "--seconds", "1",
                  "--max-motion-cm", "10", "--max-motion-deg", "30"});
  ASSERT_EQ(calibrate.wait(30.0), 0) << calibrate.err();
  Proc run({"run", "--listen", "127.0.0.1:0", "--source", "sim:walk?sensors=11", "--calibration", cal, "--duration",
            "4", "--quiet", "--json"});
  ASSERT_EQ(run.wait(30.0), 0) << run.err();
  EXPECT_NE(run.err().find("calibration refined from the motion: 2 joint centres"), std::string::npos) << run.err();
  const auto j = last_json(run.out());
  ASSERT_FALSE(j.is_discarded()) << run.out();
  EXPECT_EQ(j["loop_allocations"], 0);
  EXPECT_GT(j["frames"].get<int>(), 100);
}

}  // namespace

namespace {

// Thin clients: mesh frames of the deformed skin at the LOD mimic run offers; another is refused.
// Both skin methods: the realtime one (default) and the full one.
TEST(RunSubscribe, ThinClientGetsMeshFramesAtTheOfferedLod) {
  for (const auto& [method, lod] : {std::pair{"realtime", "2"}, std::pair{"full", "3"}}) {
    Proc run(
        {"run", "--listen", "127.0.0.1:0", "--mesh-lod", lod, "--mesh-method", method, "--duration", "8", "--quiet"});
    const std::string ep = endpoint_of(run);
    ASSERT_FALSE(ep.empty()) << run.err();
    Proc thin({"subscribe", "--connect", ep, "--count", "30", "--mesh-lod", lod, "--json"});
    ASSERT_EQ(thin.wait(15.0), 0) << thin.err();
    const auto j = last_json(thin.out());
    ASSERT_FALSE(j.is_discarded()) << thin.out();
    EXPECT_GE(j["mesh_frames"].get<int>(), 20) << method;
    // Another LOD is refused, with the one served.
    Proc other({"subscribe", "--connect", ep, "--count", "30", "--mesh-lod", "0", "--json"});
    EXPECT_NE(other.wait(15.0), 0) << other.err();
    EXPECT_NE(other.err().find(std::string("mesh LOD 0 is not served here (served: ") + lod + ")"), std::string::npos)
        << other.err();
  }
}

}  // namespace

namespace {

// The JSON summary a running mimic prints on SIGUSR1.
nlohmann::json json_now(Proc& p) {
  const size_t mark = p.out().size();
  p.signal(SIGUSR1);
  if (!p.wait_for_out("\n", 10.0, mark)) return nlohmann::json();
  return last_json(p.out());
}

// A subscriber on a raw socket that asks for a key frame of `avatar` over and over, reading
// (and dropping) what it is sent, then says BYE.
bool request_keys(const std::string& endpoint, uint16_t avatar, int requests) {
  const size_t colon = endpoint.rfind(':');
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(uint16_t(std::stoi(endpoint.substr(colon + 1))));
  if (::inet_pton(AF_INET, endpoint.substr(0, colon).c_str(), &addr.sin_addr) != 1) return false;
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
  std::array<uint8_t, 512> out{};
  std::vector<uint8_t> in(1 << 16);
  auto send_all = [&](size_t n) { return n > 0 && ::send(fd, out.data(), n, MSG_NOSIGNAL) == ssize_t(n); };
  mimic::net::Hello hello;
  hello.capabilities = mimic::net::kCapPose | mimic::net::kCapLeanPose;
  hello.name = "key-requester";
  ok = ok && send_all(mimic::net::encode_hello(hello, out));
  for (int i = 0; ok && i < requests; ++i) {
    ok = send_all(mimic::net::encode_key_request(avatar, out));
    pollfd p{fd, POLLIN, 0};
    for (int k = 0; ok && k < 4 && ::poll(&p, 1, 5) > 0; ++k) ok = ::recv(fd, in.data(), in.size(), 0) > 0;
  }
  ok = ok && send_all(mimic::net::encode_bye(out));
  ::close(fd);
  return ok;
}

// The realtime loop never allocates (`loop_allocations`, counted once it has warmed up): not
// when a subscriber of any kind joins or leaves it afterwards — a mesh subscriber (at the
// finest LOD too, whose topology and frames the kernel cannot take at once), a UDP subscriber
// registering its address, lean and POSE subscribers, several at once, a key request.
TEST(RunSubscribe, SubscribersJoiningAndLeavingCostTheLoopNoAllocation) {
  for (const char* lod : {"2", "0"}) {
    Proc run({"run", "--listen", "127.0.0.1:0", "--mesh-lod", lod, "--duration", "90", "--quiet", "--json"});
    const std::string ep = endpoint_of(run);
    ASSERT_FALSE(ep.empty()) << run.err();
    // Past the warm-up (100 frames) before anyone joins: joins during it would not count.
    nlohmann::json j;
    for (int i = 0; i < 200 && !(j = json_now(run)).is_discarded() && j.value("frames", 0) < 120; ++i) ::usleep(20000);
    ASSERT_GE(j.value("frames", 0), 120) << run.err();
    ASSERT_EQ(j["loop_allocations"], 0);
    auto joined = [&](const std::vector<std::string>& args, const char* who) {
      Proc sub(args);
      EXPECT_EQ(sub.wait(30.0), 0) << who << ": " << sub.err();
      const auto s = last_json(sub.out());
      EXPECT_FALSE(s.is_discarded()) << who << ": " << sub.out();
      const auto r = json_now(run);
      EXPECT_EQ(r["loop_allocations"], 0) << who << " joined and left, at LOD " << lod;
      return s;
    };
    const auto mesh =
        joined({"subscribe", "--connect", ep, "--mesh-lod", lod, "--count", "60", "--json"}, "a mesh subscriber");
    EXPECT_GE(mesh["mesh_frames"].get<int>(), 30) << lod;
    const auto udp = joined({"subscribe", "--connect", ep, "--udp", "--count", "60", "--json"}, "a UDP subscriber");
    EXPECT_GE(udp["udp_frames"].get<int>(), 30);
    joined({"subscribe", "--connect", ep, "--no-lean", "--count", "60", "--json"}, "a POSE subscriber");
    {
      std::vector<std::unique_ptr<Proc>> many;
      for (int i = 0; i < 6; ++i)
        many.push_back(std::make_unique<Proc>(std::vector<std::string>{"subscribe", "--connect", ep, "--count", "90",
                                                                       i % 2 ? "--udp" : "--no-lean", "--json"}));
      joined({"subscribe", "--connect", ep, "--mesh-lod", lod, "--count", "90", "--json"}, "seven subscribers");
      for (auto& p : many) EXPECT_EQ(p->wait(30.0), 0) << p->err();
    }
    ASSERT_TRUE(request_keys(ep, 1, 30));
    // The last requests may still be in the socket when request_keys returns (a loaded machine).
    for (int i = 0; i < 250 && !(j = json_now(run)).is_discarded() && j["server"].value("key_requests", 0) < 30; ++i)
      ::usleep(20000);
    run.signal(SIGINT);
    ASSERT_EQ(run.wait(15.0), 0) << run.err();
    const auto r = last_json(run.out());
    EXPECT_EQ(r["loop_allocations"], 0) << "after key requests, at LOD " << lod;
    EXPECT_GE(r["server"]["key_requests"].get<int>(), 30);
  }
}

}  // namespace

}  // namespace run_subscribe_test
