// The browser viewer end to end: a real `mimic run --http 127.0.0.1:0`, a real headless
// Chromium loading its page, and the page's own report of what it drew (it reads its canvas
// back: the share of body pixels and a checksum, twice a second; web/page/viewer.js).
// Skipped, saying why, when Chromium or the WebAssembly skin is not there.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "mimic_proc.h"
#include "web_support.h"

namespace browser_test {

using ::mimic::test::Proc;
namespace web = ::mimic::test::web;

TEST(BrowserViewer, ShowsTheAvatarMovingAndASecondOneWhenItIsAdded) {
  if (auto why = web::skip_reason(); !why.empty()) GTEST_SKIP() << why;
  // One avatar first; a second run's avatar joins the same scene through --publish.
  Proc run({"run", "--quiet", "--listen", "127.0.0.1:0", "--no-udp", "--http", "127.0.0.1:0", "--source", "sim:walk"});
  const std::string first = run.first_line(30);
  const std::string url = web::page_url(first);
  ASSERT_FALSE(url.empty()) << first << run.err();

  web::Chromium browser;
  ASSERT_TRUE(browser.ok());
  // ?bench=1: the page also times its WebAssembly deform at every LOD (docs/browser.md's figures).
  ASSERT_TRUE(browser.open(url + "?bench=1")) << "Chromium did not open " << url;
  // Drawing for a while: three captures (half a second apart) or more of a moving avatar.
  nlohmann::json one = browser.wait_report(
      [](const nlohmann::json& r) {
        const auto c = r.value("captures", nlohmann::json::array());
        return r.value("frames", 0.0) > 10 && c.size() >= 3 && r.contains("bench") &&
               c.back()["t_ms"].get<double>() - c.front()["t_ms"].get<double>() >= 1000;
      },
      90);
  ASSERT_TRUE(one.is_object()) << "no report from the page";
  ASSERT_TRUE(one["error"].is_null()) << one.dump();
  EXPECT_TRUE(one["welcomed"].get<bool>()) << one.dump();
  EXPECT_EQ(one["avatars"].get<int>(), 1) << one.dump();
  const auto& caps = one["captures"];
  ASSERT_GE(caps.size(), 3u) << one.dump();
  // The avatar covers a sane part of the canvas: visible, and far from all of it.
  const double coverage = caps.back()["coverage"].get<double>();
  EXPECT_GT(coverage, 0.005) << one.dump();
  EXPECT_LT(coverage, 0.6) << one.dump();
  // The page's deform bench ran at every LOD (figures, not limits: printed on request below).
  ASSERT_TRUE(one.contains("bench")) << one.dump();
  ASSERT_EQ(one["bench"]["deform_us"].size(), 4u) << one.dump();
  for (const auto& us : one["bench"]["deform_us"]) EXPECT_GT(us.get<double>(), 0) << one.dump();
  // Captures a second apart differ: the avatar walks.
  const auto& last = caps.back();
  const nlohmann::json* before = nullptr;
  for (const auto& c : caps)
    if (c["t_ms"].get<double>() <= last["t_ms"].get<double>() - 900) before = &c;
  ASSERT_NE(before, nullptr) << one.dump();
  EXPECT_NE((*before)["checksum"], last["checksum"]) << one.dump();

  // A second source joins the scene (another run publishing into it): two avatars drawn.
  const std::string scene = ::mimic::test::endpoint_of(run, 1);
  ASSERT_FALSE(scene.empty()) << first;
  Proc second({"run", "--quiet", "--publish", scene, "--source", "sim:walk"});
  nlohmann::json two = browser.wait_report(
      [](const nlohmann::json& r) {
        const auto c = r.value("captures", nlohmann::json::array());
        return r.value("avatars", 0) == 2 && r.value("lods", nlohmann::json::object()).size() == 2 && !c.empty() &&
               c.back().value("avatars", 0) == 2;
      },
      90);
  ASSERT_TRUE(two.is_object());
  EXPECT_EQ(two["avatars"].get<int>(), 2) << two.dump();
  EXPECT_EQ(two["lods"].size(), 2u) << two.dump();
  EXPECT_EQ(two["captures"].back()["avatars"].get<int>(), 2) << two.dump();
  EXPECT_GT(two["captures"].back()["coverage"].get<double>(), 0.005) << two.dump();
  // For a look (and docs/browser.md's picture): the page as drawn.
  if (const char* shot = std::getenv("MIMIC_BROWSER_SCREENSHOT"))
    std::ofstream(shot, std::ios::binary) << browser.screenshot_png();
  if (std::getenv("MIMIC_BROWSER_REPORT"))
    std::printf("one avatar: %s\ntwo avatars: %s\n", one.dump().c_str(), two.dump().c_str());
}

}  // namespace browser_test
