// End to end: `mimic record` from a simulated source, then `mimic replay --csv`, on the built
// program.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "replay_csv.h"
#include "test_data.h"

namespace record_replay_test {

namespace {

namespace fs = std::filesystem;

struct ShellRun {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

ShellRun run_shell(const std::string& command) {
  const fs::path dir = fs::temp_directory_path();
  const std::string out_file = (dir / ("mimic_cli_rr_out_" + std::to_string(::getpid()))).string();
  const std::string err_file = (dir / ("mimic_cli_rr_err_" + std::to_string(::getpid()))).string();
  const int status = std::system(("( " + command + " ) >" + out_file + " 2>" + err_file).c_str());
  ShellRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  r.out = slurp(out_file);
  r.err = slurp(err_file);
  fs::remove(out_file);
  fs::remove(err_file);
  return r;
}

std::string mimic() {
  std::string quoted = "'";
  quoted += mimic::test::mimic_binary();
  quoted += "'";
  return quoted;
}

std::string work_dir() {
  const fs::path d = fs::temp_directory_path() / ("mimic_cli_record_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d.string();
}

using mimic::test::parse_csv;

// Copies `from` to `to` with one bit flipped halfway through the file.
void flip_bit_in_the_middle(const std::string& from, const std::string& to) {
  std::ifstream in(from, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 1000u);
  bytes[bytes.size() / 2] = char(bytes[bytes.size() / 2] ^ 0x04);
  std::ofstream out(to, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

TEST(CliRecordReplay, RecordsASimulatedWalkAndReplaysItAsCsv) {
  const std::string log = work_dir() + "/walk.mlog";
  const ShellRun rec = run_shell(
      mimic() + " record --source 'sim:walk?sensors=6&rate=100' --duration 1 --seed 7 --out '" + log + "' --quiet");
  ASSERT_EQ(rec.exit_code, 0) << rec.err;
  EXPECT_NE(rec.err.find("samples"), std::string::npos) << rec.err;
  EXPECT_FALSE(fs::exists(log + ".part"));

  const ShellRun rep = run_shell(mimic() + " replay '" + log + "' --csv --speed 0");
  ASSERT_EQ(rep.exit_code, 0) << rep.err;
  const auto rows = parse_csv(rep.out);
  // One second at 100 Hz for 6 sensors, give or take the start-up and stop ticks.
  EXPECT_GE(rows.size(), 6u * 90u);
  EXPECT_LE(rows.size(), 6u * 115u);
  EXPECT_EQ(rows.size() % 6, 0u) << "whole ticks only";
  double prev_t = -1e300;
  int counts[6] = {};
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    ASSERT_GE(r.sensor, 0);
    ASSERT_LT(r.sensor, 6);
    EXPECT_EQ(r.sensor, static_cast<int>(i % 6)) << "sensors in layout order within a tick";
    ++counts[r.sensor];
    EXPECT_GE(r.t, prev_t);
    prev_t = r.t;
    const double qn = std::sqrt(r.v[3] * r.v[3] + r.v[4] * r.v[4] + r.v[5] * r.v[5] + r.v[6] * r.v[6]);
    EXPECT_NEAR(qn, 1.0, 1e-5);
    EXPECT_GT(r.v[1], -0.1) << "sensor below the floor";
    EXPECT_LT(r.v[1], 2.2) << "sensor above a standing person";
  }
  for (int c : counts) EXPECT_EQ(c, counts[0]);
  // The head (sensor 0) rides highest.
  EXPECT_GT(rows[0].v[1], rows[3].v[1]);
  // Ticks are 10 ms apart.
  EXPECT_NEAR(rows[6].t - rows[0].t, 0.01, 1e-5);

  // Same seed, same samples: a second recording matches sample for sample (time stamps aside).
  const std::string log2 = work_dir() + "/walk2.mlog";
  ASSERT_EQ(run_shell(mimic() + " record --source 'sim:walk?sensors=6&rate=100&seed=7' --duration 0.3 --out '" + log2 +
                      "' --quiet")
                .exit_code,
            0);
  const auto rows2 = parse_csv(run_shell(mimic() + " replay '" + log2 + "' --csv --speed 0").out);
  ASSERT_GE(rows2.size(), 6u * 20u);
  for (size_t i = 0; i < 6u * 20u; ++i)
    for (int k = 0; k < 7; ++k) EXPECT_EQ(rows2[i].v[k], rows[i].v[k]) << "sample " << i;
}

TEST(CliRecordReplay, DamagedLogReplaysTheGoodPartAndSaysWhereItStopped) {
  const std::string dir = work_dir();
  const std::string log = dir + "/whole.mlog", cut = dir + "/cut.mlog";
  ASSERT_EQ(
      run_shell(mimic() + " record --source 'sim:idle?sensors=3' --duration 0.3 --out '" + log + "' --quiet").exit_code,
      0);
  const auto whole = parse_csv(run_shell(mimic() + " replay '" + log + "' --csv --speed 0").out);
  ASSERT_GT(whole.size(), 30u);
  // Cut the file inside the fifth-last sample record (the end record is 17 bytes, samples 63).
  const auto size = fs::file_size(log);
  fs::copy_file(log, cut, fs::copy_options::overwrite_existing);
  fs::resize_file(cut, size - 17 - 4 * 63 - 20);
  const ShellRun rep = run_shell(mimic() + " replay '" + cut + "' --csv --speed 0");
  EXPECT_EQ(rep.exit_code, 1);
  const auto rows = parse_csv(rep.out);
  EXPECT_EQ(rows.size(), whole.size() - 5);
  const auto stop_at = size - 17 - 5 * 63;
  EXPECT_NE(rep.err.find("damage at byte " + std::to_string(stop_at)), std::string::npos) << rep.err;
  for (size_t i = 0; i < rows.size(); ++i) EXPECT_EQ(rows[i].v[0], whole[i].v[0]);
}

// One flipped bit in the middle of a recording costs one sample: replay skips to the next good
// record, reports where and how much, and exits 1; `run --source replay:` says so too.
TEST(CliRecordReplay, FlippedBitInTheMiddleKeepsTheRest) {
  const std::string dir = work_dir();
  const std::string log = dir + "/long.mlog", flipped = dir + "/long_flipped.mlog";
  ASSERT_EQ(
      run_shell(mimic() + " record --source 'sim:idle?sensors=3' --duration 1 --out '" + log + "' --quiet").exit_code,
      0);
  const auto whole = parse_csv(run_shell(mimic() + " replay '" + log + "' --csv --speed 0").out);
  ASSERT_GT(whole.size(), 200u);
  flip_bit_in_the_middle(log, flipped);
  const ShellRun rep = run_shell(mimic() + " replay '" + flipped + "' --csv --speed 0");
  EXPECT_EQ(rep.exit_code, 1);
  const auto rows = parse_csv(rep.out);
  EXPECT_GE(rows.size() * 100, whole.size() * 99);
  EXPECT_EQ(rows.size(), whole.size() - 1);
  EXPECT_EQ(rows.back().v[0], whole.back().v[0]);
  EXPECT_NE(rep.err.find("63 bytes skipped, reading resumed at byte"), std::string::npos) << rep.err;
  EXPECT_NE(rep.err.find("1 samples lost"), std::string::npos) << rep.err;
  const ShellRun run =
      run_shell(mimic() + " run --source 'replay:" + flipped + "' --duration 0.3 --quiet --listen 127.0.0.1:0");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("damage at byte"), std::string::npos) << run.err;
}

TEST(CliRecordReplay, CtrlCLeavesACompleteLog) {
  const std::string log = work_dir() + "/interrupted.mlog";
  const ShellRun rec = run_shell("( " + mimic() + " record --source sim:walk --out '" + log +
                                 "' --quiet & pid=$!; sleep 0.6; kill -INT $pid; wait $pid )");
  ASSERT_EQ(rec.exit_code, 0) << rec.err;
  EXPECT_NE(rec.err.find("interrupted"), std::string::npos) << rec.err;
  const ShellRun rep = run_shell(mimic() + " replay '" + log + "' --csv --speed 0");
  EXPECT_EQ(rep.exit_code, 0) << "log not closed cleanly: " << rep.err;
  EXPECT_GT(parse_csv(rep.out).size(), 6u * 10u);
}

TEST(CliRecordReplay, RecordsAVirtualFlockThroughTheDriver) {
  // `mimic sim flock` serves three birds on a pty (its first output line is the path; the walk
  // needs the extended range controller, which it adds and announces on stderr);
  // `mimic record --source flock:PATH?erc=1` reads them with the real driver.
  const std::string dir = work_dir();
  const std::string log = dir + "/flock.mlog", sim_out = dir + "/sim.txt";
  const ShellRun rec = run_shell("M=" + mimic() + "; $M sim flock --birds 3 --motion walk --seed 2 --busy 0.05 >'" +
                                 sim_out + "' 2>/dev/null & S=$!; for i in $(seq 50); do [ -s '" + sim_out +
                                 "' ] && break; sleep 0.1; done; P=$(head -1 '" + sim_out +
                                 "'); $M record --source \"flock:$P?birds=3&erc=1\" --duration 2 --out '" + log +
                                 "' --quiet; R=$?; kill -INT $S; wait $S; exit $R");
  ASSERT_EQ(rec.exit_code, 0) << rec.err;
  const ShellRun rep = run_shell(mimic() + " replay '" + log + "' --csv --speed 0");
  ASSERT_EQ(rep.exit_code, 0) << rep.err;
  const auto rows = parse_csv(rep.out);
  int counts[5] = {};
  for (const auto& r : rows) {
    ASSERT_GE(r.sensor, 0);
    ASSERT_LE(r.sensor, 2) << "three birds, at FBB addresses 2..4 behind the ERC";
    ++counts[r.sensor];
    const double qn = std::sqrt(r.v[3] * r.v[3] + r.v[4] * r.v[4] + r.v[5] * r.v[5] + r.v[6] * r.v[6]);
    EXPECT_NEAR(qn, 1.0, 1e-3);
    for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(r.v[k]), 3.65) << "pinned at the 144-inch range";
    EXPECT_GE(r.v[2], 0.0) << "behind the transmitter (mirrored by the hemisphere)";
  }
  // About 103 records per second per bird once the driver has configured the flock.
  for (int b = 0; b < 3; ++b) EXPECT_GE(counts[b], 60) << "bird " << b;
  // The header names the birds the driver found.
  const ShellRun info = run_shell(mimic() + " replay '" + log + "' --speed 0");
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.err.find(", 3 sensors"), std::string::npos) << info.err;
}

// --raw keeps the bytes of the session; --through-driver plays them to the driver again and
// gets the recorded samples back, bit for bit.
TEST(CliRecordReplay, RawFlockSessionReplaysThroughTheDriver) {
  const std::string dir = work_dir();
  const std::string log = dir + "/flock_raw.mlog", plain = dir + "/flock_plain.mlog", sim_out = dir + "/sim_raw.txt";
  const ShellRun rec = run_shell("M=" + mimic() + "; $M sim flock --birds 2 --motion walk --seed 4 --busy 0.05 >'" +
                                 sim_out + "' 2>/dev/null & S=$!; for i in $(seq 50); do [ -s '" + sim_out +
                                 "' ] && break; sleep 0.1; done; P=$(head -1 '" + sim_out +
                                 "'); $M record --source \"flock:$P?birds=2&erc=1\" --duration 1 --raw --out '" + log +
                                 "' --quiet; R=$?; kill -INT $S; wait $S; exit $R");
  ASSERT_EQ(rec.exit_code, 0) << rec.err;
  EXPECT_NE(rec.err.find("raw bytes kept"), std::string::npos) << rec.err;
  const ShellRun rep = run_shell(mimic() + " replay '" + log + "' --through-driver --json");
  ASSERT_EQ(rep.exit_code, 0) << rep.out << rep.err;
  const auto j = nlohmann::json::parse(rep.out);
  EXPECT_GT(j["samples_recorded"].get<int>(), 100);
  EXPECT_EQ(j["identical"], j["samples_recorded"]);
  EXPECT_GE(j["samples_decoded"].get<int>(), j["samples_recorded"].get<int>());
  EXPECT_TRUE(j["first_difference"].is_null());
  EXPECT_EQ(j["damaged"], false);

  // The same session with one flipped bit in the middle: the driver run cannot vouch for it,
  // and the command says why with exit status 1 (its --help promises so).
  const std::string flipped = dir + "/flock_raw_flipped.mlog";
  flip_bit_in_the_middle(log, flipped);
  const ShellRun bad = run_shell(mimic() + " replay '" + flipped + "' --through-driver");
  EXPECT_EQ(bad.exit_code, 1) << bad.err;
  EXPECT_NE(bad.err.find("damaged log, damage at byte"), std::string::npos) << bad.err;

  // A log without raw bytes, and a simulated one, say why they cannot.
  ShellRun r = run_shell(mimic() + " record --source sim:walk --duration 0.2 --quiet --out '" + plain + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_shell(mimic() + " replay '" + plain + "' --through-driver");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no raw bytes"), std::string::npos) << r.err;
  r = run_shell(mimic() + " record --source sim:walk --raw --out '" + plain + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--raw needs a serial device"), std::string::npos) << r.err;
}

TEST(CliRecordReplay, UsageErrorsAreClear) {
  ShellRun r = run_shell(mimic() + " record --out /tmp/x.mlog");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--source"), std::string::npos) << r.err;
  r = run_shell(mimic() + " record --source 'sim:walk?sensors=7' --out /tmp/x.mlog");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("sensors"), std::string::npos) << r.err;
  r = run_shell(mimic() + " record --source spacemouse --out /tmp/x.mlog --duration 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("6-DOF input"), std::string::npos) << r.err;
  r = run_shell(mimic() + " replay /nonexistent.mlog");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/nonexistent.mlog"), std::string::npos) << r.err;
  r = run_shell(mimic() + " replay --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("host_time_s,sensor,x_m,y_m,z_m,qw,qx,qy,qz"), std::string::npos);
  r = run_shell(mimic() + " record --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--duration"), std::string::npos);
}

}  // namespace

}  // namespace record_replay_test
