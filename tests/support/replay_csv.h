// A recorded log's samples as `mimic replay --csv` prints them, for end-to-end tests.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "run_mimic.h"

namespace mimic::test {

struct CsvSample {
  double t;
  int sensor;
  double v[7];
};

// Parses replay --csv output; fails the test on any malformed line.
inline std::vector<CsvSample> parse_csv(const std::string& text) {
  std::vector<CsvSample> rows;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    CsvSample s{};
    int consumed = 0;
    const int fields = std::sscanf(line.c_str(), "%lf,%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf%n", &s.t, &s.sensor, &s.v[0],
                                   &s.v[1], &s.v[2], &s.v[3], &s.v[4], &s.v[5], &s.v[6], &consumed);
    EXPECT_EQ(fields, 9) << "line: " << line;
    EXPECT_EQ(static_cast<size_t>(consumed), line.size()) << "trailing text in line: " << line;
    rows.push_back(s);
  }
  return rows;
}

// The log's samples, read at once (--speed 0); empty, with a test failure, when replay fails.
inline std::vector<CsvSample> replay_csv(const std::string& log) {
  const Outcome r = run_mimic("replay '" + log + "' --csv --speed 0", true);
  EXPECT_EQ(r.status, 0) << "mimic replay '" << log << "' --csv";
  return r.status == 0 ? parse_csv(r.output) : std::vector<CsvSample>{};
}

// The distinct sample times of a log: its measurement cycles. A busy machine records a little
// more than the --duration asked of `mimic record`, so tests count what the log holds.
inline std::set<double> cycle_times(const std::vector<CsvSample>& samples) {
  std::set<double> times;
  for (const auto& s : samples) times.insert(s.t);
  return times;
}

}  // namespace mimic::test
