// The page's Enter VR path in a real headless Chromium. No headset is here, so the WebXR device is
// emulated in the page, as the WebXR API Emulator extension does it: `navigator.xr` offers an
// immersive-vr session whose viewer stands at 1.6 m, eyes 64 mm apart, each eye a 90° view on
// its own half of the canvas. Everything after that is the page's own code (its XR frame loop,
// its layer viewports, its deform and draw). Skipped, saying why, without Chromium or the skin.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

#include "mimic_proc.h"
#include "web_support.h"

namespace webxr_test {

using ::mimic::test::Proc;
namespace web = ::mimic::test::web;

// The emulated device; `window.__xr.frames` counts the frames the page drew in the session.
constexpr const char* kEmulatedXr = R"JS(
(() => {
  const eyeY = 1.6, halfIpd = 0.032;
  const perspective = (fovy, aspect, near, far) => {
    const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0]);
  };
  const view = (eye, x, gl) => ({
    eye,
    projectionMatrix: perspective(Math.PI / 2, (gl.drawingBufferWidth / 2) / gl.drawingBufferHeight, 0.05, 100),
    transform: { position: { x, y: eyeY, z: 0 },
                 inverse: { matrix: new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -x, -eyeY, 0, 1]) } },
  });
  window.__xr = { frames: 0, ended: false };
  window.XRWebGLLayer = class {
    constructor(session, gl) { this.gl = gl; this.framebuffer = null; }
    get framebufferWidth() { return this.gl.drawingBufferWidth; }
    get framebufferHeight() { return this.gl.drawingBufferHeight; }
    getViewport(v) {
      const w = this.gl.drawingBufferWidth / 2;
      return { x: v.eye === 'left' ? 0 : w, y: 0, width: w, height: this.gl.drawingBufferHeight };
    }
  };
  WebGL2RenderingContext.prototype.makeXRCompatible = () => Promise.resolve();
  class Session extends EventTarget {
    constructor() { super(); this.renderState = {}; }
    updateRenderState(s) { Object.assign(this.renderState, s); }
    requestReferenceSpace() { return Promise.resolve({}); }
    requestAnimationFrame(cb) {
      if (window.__xr.ended) return 0;
      return window.requestAnimationFrame((t) => {
        const gl = this.renderState.baseLayer.gl;
        cb(t, { getViewerPose: () => ({ transform: { position: { x: 0, y: eyeY, z: 0 } },
                                        views: [view('left', -halfIpd, gl), view('right', halfIpd, gl)] }) });
        ++window.__xr.frames;
      });
    }
    end() { window.__xr.ended = true; this.dispatchEvent(new Event('end')); return Promise.resolve(); }
  }
  Object.defineProperty(navigator, 'xr', { value: {
    isSessionSupported: (mode) => Promise.resolve(mode === 'immersive-vr'),
    requestSession: () => Promise.resolve(new Session()),
  } });
})();
)JS";

// Body pixels (the page's own rule: far from the background, not the grey grid) in each half of
// the canvas: their share and the fraction of the height their rows span.
constexpr const char* kHalves = R"JS(
(() => {
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight, px = new Uint8Array(w * h * 4);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const bg = background.map((c) => Math.round(c * 255));
  const halves = [0, 1].map(() => ({ covered: 0, low: h, high: -1, sum: 0 }));
  for (let y = 0; y < h; ++y)
    for (let x = 0; x < w; ++x) {
      const i = 4 * (y * w + x), r = px[i], g = px[i + 1], b = px[i + 2];
      const off = Math.abs(r - bg[0]) + Math.abs(g - bg[1]) + Math.abs(b - bg[2]);
      const grey = Math.max(r, g, b) - Math.min(r, g, b) < 12 && r < 110;
      const half = halves[x < w / 2 ? 0 : 1];
      half.sum = (half.sum * 31 + r + 7 * g + 13 * b) >>> 0;
      if (off > 40 && !grey) { half.covered++; half.low = Math.min(half.low, y); half.high = Math.max(half.high, y); }
    }
  return halves.map((s) => ({ coverage: s.covered / (w * h / 2), span: s.high >= s.low ? (s.high - s.low + 1) / h : 0,
                              checksum: s.sum }));
})()
)JS";

TEST(BrowserViewer, EnterVrDrawsBothEyesAtTrueScaleAndExitReturnsToTheDesktop) {
  if (auto why = web::skip_reason(); !why.empty()) GTEST_SKIP() << why;
  // One avatar standing still: at the scene's centre, which the page puts 2 m ahead of the user.
  Proc run({"run", "--quiet", "--listen", "127.0.0.1:0", "--no-udp", "--http", "127.0.0.1:0", "--source", "sim:idle"});
  const std::string url = web::page_url(run.first_line(30));
  ASSERT_FALSE(url.empty()) << run.err();
  web::Chromium browser;
  ASSERT_TRUE(browser.ok());
  ASSERT_TRUE(browser.open(url, kEmulatedXr)) << "Chromium did not open " << url;
  const nlohmann::json desk = browser.wait_report(
      [](const nlohmann::json& r) { return r.value("avatars", 0) == 1 && r.value("frames", 0.0) > 10; }, 90);
  ASSERT_TRUE(desk.is_object() && desk["error"].is_null()) << desk.dump();

  // The button offers VR (the device says immersive-vr is supported), and entering it runs the
  // page's XR frame loop.
  const auto button = [&] {
    return browser.eval(
        "[...document.querySelectorAll('button')].find((b) => /VR/.test(b.textContent))?.textContent ?? ''");
  };
  ASSERT_EQ(button(), "Enter VR");
  browser.eval("[...document.querySelectorAll('button')].find((b) => /VR/.test(b.textContent)).click()");
  nlohmann::json frames;
  for (int i = 0; i < 300 && !(frames.is_number() && frames.get<double>() > 30); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    frames = browser.eval("window.__xr.frames");
  }
  ASSERT_TRUE(frames.is_number() && frames.get<double>() > 30) << "no XR frames: " << frames.dump();
  EXPECT_EQ(button(), "Exit VR");

  // Both eyes see the avatar, from 64 mm apart (the halves differ), at true scale: a standing
  // person 2 m ahead of a 90° view spans about 1.75 / (2 · 2 · tan 45°) ≈ 0.44 of its height
  // (a scene drawn at the desktop's fitted scale would not).
  const nlohmann::json halves = browser.eval(kHalves);
  ASSERT_TRUE(halves.is_array() && halves.size() == 2) << halves.dump();
  for (const auto& eye : halves) {
    EXPECT_GT(eye["coverage"].get<double>(), 0.005) << halves.dump();
    EXPECT_GT(eye["span"].get<double>(), 0.3) << halves.dump();
    EXPECT_LT(eye["span"].get<double>(), 0.6) << halves.dump();
  }
  EXPECT_NE(halves[0]["checksum"], halves[1]["checksum"]) << halves.dump();
  std::printf("[ figure ] the two eyes in VR: %s\n", halves.dump().c_str());
  if (const char* shot = std::getenv("MIMIC_BROWSER_SCREENSHOT"))
    std::ofstream(shot, std::ios::binary) << browser.screenshot_png();

  // Exit VR: the session ends and the desktop view draws again.
  browser.eval("[...document.querySelectorAll('button')].find((b) => /VR/.test(b.textContent)).click()");
  const double before = browser.report().value("frames", 0.0);
  const nlohmann::json back =
      browser.wait_report([before](const nlohmann::json& r) { return r.value("frames", 0.0) > before + 10; }, 60);
  EXPECT_GT(back.value("frames", 0.0), before + 10) << back.dump();
  EXPECT_EQ(button(), "Enter VR");
}

}  // namespace webxr_test
