// --lean-shift and --lean-key-interval, shared by the commands that serve viewers (mimic run,
// mimic relay): the lean pose stream's precision and key frame interval (docs/protocol.md,
// "Lean pose stream"), checked against their documented bounds.
#pragma once

#include <string>

#include "cli.h"
#include "mimic/net/pose_stream.h"
#include "mimic/net/server.h"

namespace mimic::app {

inline constexpr long kMaxLeanKeyInterval = 3600;  // 40 s at 90 Hz

// An integer from 0 to `max`, its errors worded as Mimic's always were: "--lean-shift must be 0
// to 8, got 9", "--lean-key-interval expects an integer, got 'often'" (cli::Parser prints a
// message that names its option as written).
inline CLI::Validator lean_bound(const std::string& name, long max, const std::string& zero) {
  return CLI::Validator(
      [name, max, zero](std::string& input) -> std::string {
        long value = 0;
        if (!CLI::detail::lexical_cast(input, value)) return name + " expects an integer, got '" + input + "'";
        if (value < 0 || value > max)
          return name + " must be 0" + zero + " to " + std::to_string(max) + ", got " + input;
        return {};
      },
      "INT in [0 - " + std::to_string(max) + "]");
}

// Declares both flags on a command, bounds with them; they fill `o` when parsed (`o` must outlive
// the parse).
inline void add_lean_flags(CLI::App& app, net::ServerOptions& o) {
  app.add_option_function<int>(
         "--lean-shift", [&o](const int& shift) { o.lean_pose_shift = uint8_t(shift); },
         "precision of the lean pose stream viewers get by default: POSE steps\n"
         "divided by 2^N, 0 (lossless against POSE frames) to 8 (angles +/-0.012 rad,\n"
         "root +/-1.3 mm); default 3 (angles +/-4.3e-4 rad, root +/-45 um).\n"
         "Error bound: (2^N + 1)/2 POSE steps a value")
      ->type_name("N")
      ->check(lean_bound("--lean-shift", net::kMaxPoseShift, ""));
  app.add_option_function<long>(
         "--lean-key-interval", [&o](const long& frames) { o.lean_key_interval = uint32_t(frames); },
         "a key frame to every lean viewer every N frames (0: only on joining,\n"
         "after lost frames and on request); default 90 (1 s)")
      ->type_name("N")
      ->check(lean_bound("--lean-key-interval", kMaxLeanKeyInterval, " (no periodic key frames)"));
}

}  // namespace mimic::app
