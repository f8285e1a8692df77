// End to end over loopback: `mimic run` serves, `mimic subscribe` (and a second `mimic run
// --publish`) join; Ctrl-C stops the service cleanly.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mimic_proc.h"
#include "test_data.h"

extern char** environ;

namespace {

using mimic::test::Proc;

std::string endpoint_of(Proc& run) {
  const std::string line = run.first_line(10.0);
  const std::string prefix = "serving on ";
  if (line.rfind(prefix, 0) != 0) return "";
  return line.substr(prefix.size());
}

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
  for (const char* k : {"frames", "avatars", "fps", "latency_ms_p50", "latency_ms_p99", "lost", "model_bytes",
                        "frame_bytes_mean"})
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
  Proc host({"run", "--listen", "127.0.0.1:0", "--source", "sim:walk", "--source", "sim:idle?seed=2",
             "--duration", "12", "--quiet"});
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
  EXPECT_LE(r["frames"].get<int>(), 60);  // the log's 0.5 s at 100 Hz: one frame per cycle
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
  const auto r = last_json(run.out());
  ASSERT_FALSE(r.is_discarded()) << run.out() << run.err();
  // The virtual Flock measures about 100 cycles a second (four records each).
  EXPECT_GT(r["fps"].get<double>(), 40.0) << run.out();
  EXPECT_LT(r["fps"].get<double>(), 150.0) << run.out();
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
  // Every fan-out point delivered what it could account for: received + lost = expected.
  for (const auto& f : n["fanout_90hz"])
    EXPECT_EQ(f["received"].get<uint64_t>() + f["lost"].get<uint64_t>(), f["expected"].get<uint64_t>());
}

}  // namespace

namespace {

TEST(RunSubscribe, RunsWithACalibrationFromMimicCalibrate) {
  const std::string cal = ::testing::TempDir() + "run_subscribe_cal.json";
  Proc calibrate({"calibrate", "--source", "sim:idle?sensors=6", "--out", cal, "--countdown", "0", "--seconds", "1",
                  "--max-motion-cm", "10", "--max-motion-deg", "30"});
  ASSERT_EQ(calibrate.wait(30.0), 0) << calibrate.err();
  Proc run({"run", "--listen", "127.0.0.1:0", "--source", "sim:walk", "--calibration", cal, "--duration", "6", "--quiet"});
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
  const auto j = last_json(bench.out());
  ASSERT_FALSE(j.is_discarded()) << bench.out();
  ASSERT_TRUE(j["skin"].is_array()) << bench.out();
  ASSERT_EQ(j["skin"].size(), 4u);
  int previous_vertices = 1 << 30;
  for (const auto& row : j["skin"]) {
    for (const char* key : {"full_us", "realtime_us", "realtime_muscles_us", "lbs_us"})
      EXPECT_GT(row[key].get<double>(), 0.0) << key;
    EXPECT_LT(row["vertices"].get<int>(), previous_vertices) << "LODs coarsen";
    previous_vertices = row["vertices"].get<int>();
    EXPECT_GT(row["triangles"].get<int>(), row["vertices"].get<int>());
  }
  Proc solver({"bench", "--section", "solver", "--quick", "--json"});
  ASSERT_EQ(solver.wait(120.0), 0) << solver.err();
  const auto k = last_json(solver.out());
  ASSERT_FALSE(k.is_discarded()) << solver.out();
  for (const char* layout : {"3", "6", "11", "all"}) {
    EXPECT_GT(k["solver"][layout]["frames"].get<int>(), 10) << layout;
    EXPECT_LE(k["solver"][layout]["solve_us_p50"].get<double>(), k["solver"][layout]["solve_us_p99"].get<double>());
  }
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

// Thin clients: mesh frames of the deformed skin at the LOD mimic run offers; none at another.
// Both skin methods: the realtime one (default) and the full one.
TEST(RunSubscribe, ThinClientGetsMeshFramesAtTheOfferedLod) {
  for (const auto& [method, lod] : {std::pair{"realtime", "2"}, std::pair{"full", "3"}}) {
    Proc run({"run", "--listen", "127.0.0.1:0", "--mesh-lod", lod, "--mesh-method", method, "--duration", "8", "--quiet"});
    const std::string ep = endpoint_of(run);
    ASSERT_FALSE(ep.empty()) << run.err();
    Proc thin({"subscribe", "--connect", ep, "--count", "30", "--mesh-lod", lod, "--json"});
    ASSERT_EQ(thin.wait(15.0), 0) << thin.err();
    const auto j = last_json(thin.out());
    ASSERT_FALSE(j.is_discarded()) << thin.out();
    EXPECT_GE(j["mesh_frames"].get<int>(), 20) << method;
    Proc other({"subscribe", "--connect", ep, "--count", "30", "--mesh-lod", "0", "--json"});
    ASSERT_EQ(other.wait(15.0), 0) << other.err();
    const auto k = last_json(other.out());
    ASSERT_FALSE(k.is_discarded()) << other.out();
    EXPECT_EQ(k["mesh_frames"], 0) << method;
    EXPECT_EQ(k["frames"], 30);
  }
}

}  // namespace
