// `mimic bench --section web`: what the browser viewer (`mimic run --http`) costs, measured in one
// run against a real `mimic run --http` child on loopback and a real headless Chromium.
#pragma once

#include <nlohmann/json.hpp>

#include "mimic/core/result.h"

namespace mimic::app::bench_web {

// The page's deform is the WebAssembly module the page loads, timed inside the page in headless
// Chromium (V8; its ?bench=1, mw_bench_deform); the native one is the same realtime skin on the
// body model the server sent and the poses it streamed. Returns
//   {"deform": [{lod, vertices, native_us, page_us, page_over_native}],
//    "bytes_per_avatar": {lean, pose, mesh_lod0..3: {bytes_per_s, frames_per_s, bytes_per_frame,
//                         all_bytes_per_s}, model_bytes, seconds, avatars},
//    "page": {browser, deform_us, latency: {poses, p50_ms, p99_ms, max_ms}, websocket: {...}}}
// Without Chromium or the WebAssembly skin, "page" is {"skipped": why} and the deform rows have
// no page figures: the rest is measured, and the bench goes on (exit status 0).
Result<nlohmann::json> run(bool quick);

}  // namespace mimic::app::bench_web
