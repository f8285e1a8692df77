// --lean-shift and --lean-key-interval, shared by the commands that serve viewers (mimic run,
// mimic relay): the lean pose stream's precision and key frame interval (docs/protocol.md,
// "Lean pose stream"), checked against their documented bounds.
#pragma once

#include <string>

#include "cli.h"
#include "command.h"
#include "mimic/net/pose_stream.h"
#include "mimic/net/server.h"

namespace mimic::app {

inline constexpr long kMaxLeanKeyInterval = 3600;  // 40 s at 90 Hz

#define MIMIC_LEAN_FLAGS_USAGE                                                                        \
  "  --lean-shift N      precision of the lean pose stream viewers get by default: POSE steps\n"      \
  "                      divided by 2^N, 0(lossless against POSE frames) to\n"                        \
  "                      8 (angles +/-0.012 rad, root +/-1.3 mm); default 3 (angles +/-4.3e-4 rad,\n" \
  "                      root +/-45 um). Error bound: (2^N + 1)/2 POSE steps a value\n"               \
  "  --lean-key-interval N  a key frame to every lean viewer every N frames (1-3600; 0: only\n"       \
  "                      on joining, after lost frames and on request); default 90 (1 s)\n"

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
      ->check(CLI::Range(0, int(net::kMaxPoseShift)));
  app.add_option_function<long>(
         "--lean-key-interval", [&o](const long& frames) { o.lean_key_interval = uint32_t(frames); },
         "a key frame to every lean viewer every N frames (0: only on joining,\n"
         "after lost frames and on request); default 90 (1 s)")
      ->type_name("N")
      ->check(CLI::Range(0L, kMaxLeanKeyInterval));
}

// The old parser's form (mimic run): reads both flags into `o`; an error message naming the flag
// and its bounds, or "".
inline std::string take_lean_flags(Args& a, net::ServerOptions& o) {
  long shift = o.lean_pose_shift, interval = long(o.lean_key_interval);
  if (!a.get_int("lean-shift", shift) || !a.get_int("lean-key-interval", interval)) return a.error();
  if (shift < 0 || shift > net::kMaxPoseShift) return "--lean-shift must be 0 to 8, got " + std::to_string(shift);
  if (interval < 0 || interval > kMaxLeanKeyInterval)
    return "--lean-key-interval must be 0 (no periodic key frames) to 3600 frames, got " + std::to_string(interval);
  o.lean_pose_shift = uint8_t(shift);
  o.lean_key_interval = uint32_t(interval);
  return "";
}

}  // namespace mimic::app
