// `mimic bench --section web` runs whole: a real `mimic run --http` child, the page in headless
// Chromium, subscribers on loopback. The figures are checked for sanity, not speed; without
// Chromium or the WebAssembly skin the section says why it skipped and the bench still succeeds.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "mimic_proc.h"
#include "web_support.h"

namespace bench_web_test {

using ::mimic::test::Proc;
namespace web = ::mimic::test::web;

nlohmann::json last_json_line(const std::string& out) {
  const size_t end = out.find_last_not_of('\n');
  if (end == std::string::npos) return nlohmann::json::value_t::discarded;
  const size_t start = out.rfind('\n', end);
  return nlohmann::json::parse(out.substr(start == std::string::npos ? 0 : start + 1, end + 1), nullptr, false);
}

TEST(Bench, WebSectionComparesThePagesDeformWithNativeAndCountsBytesAndLatency) {
  Proc bench({"bench", "--section", "web", "--quick", "--json"});
  ASSERT_EQ(bench.wait(240.0), 0) << bench.err();
  const nlohmann::json all = last_json_line(bench.out());
  ASSERT_TRUE(all.is_object()) << bench.out();
  ASSERT_TRUE(all.contains("web")) << all.dump();
  const nlohmann::json& w = all["web"];
  // The subscribers' figures come whatever the browser: the lean stream is tens of bytes a
  // frame and frames flow; POSE frames are larger; mesh frames cost far more, less at coarser LODs.
  const auto& b = w["bytes_per_avatar"];
  const auto& lean = b["lean"];
  EXPECT_GT(lean["frames_per_s"].get<double>(), 10) << b.dump();
  EXPECT_GT(lean["bytes_per_frame"].get<double>(), 20) << b.dump();
  EXPECT_LT(lean["bytes_per_frame"].get<double>(), b["pose"]["bytes_per_frame"].get<double>()) << b.dump();
  EXPECT_GT(b["model_bytes"].get<double>(), 1000) << b.dump();
  for (int lod = 0; lod < 4; ++lod) {
    const auto& m = b["mesh_lod" + std::to_string(lod)];
    EXPECT_GT(m["bytes_per_s"].get<double>(), 10 * lean["bytes_per_s"].get<double>()) << b.dump();
    if (lod > 0)
      EXPECT_LT(m["bytes_per_frame"].get<double>(),
                b["mesh_lod" + std::to_string(lod - 1)]["bytes_per_frame"].get<double>())
          << b.dump();
  }
  // Four LODs timed natively, fewer vertices at each step.
  ASSERT_EQ(w["deform"].size(), 4u) << w.dump();
  for (size_t i = 0; i < 4; ++i) {
    const auto& d = w["deform"][i];
    EXPECT_EQ(d["lod"].get<size_t>(), i);
    EXPECT_GT(d["native_us"].get<double>(), 0) << d.dump();
    if (i > 0) EXPECT_LT(d["vertices"].get<size_t>(), w["deform"][i - 1]["vertices"].get<size_t>());
  }
  const auto& page = w["page"];
  if (const std::string why = web::skip_reason(); !why.empty()) {
    ASSERT_TRUE(page.contains("skipped")) << w.dump();
    EXPECT_FALSE(page["skipped"].get<std::string>().empty());
    GTEST_SKIP() << why;
  }
  ASSERT_FALSE(page.contains("skipped")) << w.dump();
  // The page's deform at every LOD against native; its WebSocket carried the lean stream.
  for (const auto& d : w["deform"]) {
    EXPECT_GT(d["page_us"].get<double>(), 0) << d.dump();
    EXPECT_GT(d["page_over_native"].get<double>(), 0) << d.dump();
  }
  EXPECT_GT(page["websocket"]["frames_per_s"].get<double>(), 10) << page.dump();
  EXPECT_LT(page["websocket"]["bytes_per_frame"].get<double>(), b["pose"]["bytes_per_frame"].get<double>())
      << page.dump();
  // Its latency: poses were drawn, the percentiles ordered and positive (the server and the
  // browser share this machine's wall clock).
  const auto& lat = page["latency"];
  ASSERT_TRUE(lat.is_object()) << page.dump();
  EXPECT_GT(lat["poses"].get<int>(), 10) << lat.dump();
  EXPECT_GT(lat["p50_ms"].get<double>(), 0) << lat.dump();
  EXPECT_GE(lat["p99_ms"].get<double>(), lat["p50_ms"].get<double>()) << lat.dump();
}

}  // namespace bench_web_test
