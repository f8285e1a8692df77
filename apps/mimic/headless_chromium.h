// A headless Chromium driven over the DevTools protocol, for what runs the browser viewer's page
// in a real browser: `mimic bench --section web` and the browser tests (tests/web). Header-only:
// the tests include it as it is.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace mimic::app {

// Debian's chromium (scripts/setup.sh installs it); empty when there is none.
inline std::string chromium_path() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (::access(p, X_OK) == 0) return p;
  return "";
}

// A headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe:
// JSON messages ending in NUL, on its descriptors 3 and 4), in real time: the page runs as in
// any browser, and the test asks it for its report whenever it likes.
class HeadlessChromium {
 public:
  HeadlessChromium() {
    char dir[] = "/tmp/mimic-chromium-XXXXXX";
    if (!::mkdtemp(dir)) return;
    profile_ = dir;
    int to[2], from[2];
    if (::pipe(to) != 0 || ::pipe(from) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, to[0], 3);
    posix_spawn_file_actions_adddup2(&fa, from[1], 4);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    std::vector<std::string> args = {chromium_path(),
                                     "--headless=new",
                                     "--no-sandbox",
                                     "--no-first-run",
                                     "--disable-extensions",
                                     "--use-angle=swiftshader",
                                     "--enable-unsafe-swiftshader",
                                     "--ignore-gpu-blocklist",
                                     "--window-size=640,480",
                                     "--remote-debugging-pipe",
                                     "--user-data-dir=" + profile_,
                                     "about:blank"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ok_ = posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    ::close(to[0]);
    ::close(from[1]);
    to_ = to[1];
    from_ = from[0];
  }
  ~HeadlessChromium() {
    if (ok_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    ::close(to_);
    ::close(from_);
    std::error_code ec;
    if (!profile_.empty()) std::filesystem::remove_all(profile_, ec);
  }

  // Opens `url` in the browser's page, `init_script` run before the page's own scripts; false
  // when the browser did not answer.
  bool open(const std::string& url, const std::string& init_script = {}) {
    const auto targets = call("Target.getTargets", nlohmann::json::object(), false);
    for (const auto& t : targets.value("targetInfos", nlohmann::json::array()))
      if (t.value("type", "") == "page") {
        const auto a = call("Target.attachToTarget", {{"targetId", t["targetId"]}, {"flatten", true}}, false);
        session_ = a.value("sessionId", "");
        break;
      }
    if (session_.empty()) return false;
    if (!init_script.empty() && (!call("Page.enable", nlohmann::json::object()).is_object() ||
                                 !call("Page.addScriptToEvaluateOnNewDocument", {{"source", init_script}}).is_object()))
      return false;
    return call("Page.navigate", {{"url", url}}).is_object();
  }

  // The value of a JavaScript expression in the page (null on failure).
  nlohmann::json eval(const std::string& expression) {
    const auto r = call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}});
    return r.contains("result") ? r["result"].value("value", nlohmann::json()) : nlohmann::json();
  }

  // The page's report (#stats), parsed; null when it has none yet.
  nlohmann::json report() {
    const auto text = eval("document.getElementById('stats') && document.getElementById('stats').textContent");
    return text.is_string() ? nlohmann::json::parse(text.get<std::string>(), nullptr, false) : nlohmann::json();
  }

  // Polls the report until `done(report)` holds or `timeout_s` passes; the last report.
  template <class Pred>
  nlohmann::json wait_report(Pred done, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    nlohmann::json r;
    while (std::chrono::steady_clock::now() < end) {
      r = report();
      if (r.is_object() && done(r)) return r;
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
    return r;
  }

  // A PNG of the page as drawn (empty on failure).
  std::string screenshot_png() {
    const auto r = call("Page.captureScreenshot", {{"format", "png"}});
    return r.contains("data") ? base64_decode(r["data"].get<std::string>()) : "";
  }

  // The browser's product and version ("Chrome/150.0…"), empty when it did not answer.
  std::string version() {
    const auto r = call("Browser.getVersion", nlohmann::json::object(), false);
    return r.is_object() ? r.value("product", "") : "";
  }

  bool ok() const { return ok_; }

 private:
  nlohmann::json call(const std::string& method, const nlohmann::json& params, bool in_page = true,
                      double timeout_s = 60) {
    const int id = next_id_++;
    nlohmann::json m = {{"id", id}, {"method", method}, {"params", params}};
    if (in_page) m["sessionId"] = session_;
    const std::string text = m.dump() + std::string(1, '\0');
    if (::write(to_, text.data(), text.size()) != ssize_t(text.size())) return nullptr;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      for (size_t nul; (nul = buf_.find('\0')) != std::string::npos;) {
        auto msg = nlohmann::json::parse(buf_.substr(0, nul), nullptr, false);
        buf_.erase(0, nul + 1);
        if (msg.is_object() && msg.value("id", -1) == id) return msg.value("result", nlohmann::json());
      }
      pollfd p{from_, POLLIN, 0};
      if (::poll(&p, 1, 200) <= 0) continue;
      char b[65536];
      const ssize_t n = ::read(from_, b, sizeof b);
      if (n <= 0) return nullptr;
      buf_.append(b, size_t(n));
    }
    return nullptr;
  }

  static std::string base64_decode(const std::string& in) {
    std::string out;
    int val = 0, bits = -8;
    for (unsigned char c : in) {
      int d = c >= 'A' && c <= 'Z'   ? c - 'A'
              : c >= 'a' && c <= 'z' ? c - 'a' + 26
              : c >= '0' && c <= '9' ? c - '0' + 52
              : c == '+'             ? 62
              : c == '/'             ? 63
                                     : -1;
      if (d < 0) continue;
      val = (val << 6) + d;
      bits += 6;
      if (bits >= 0) {
        out.push_back(char((val >> bits) & 0xFF));
        bits -= 8;
      }
    }
    return out;
  }

  pid_t pid_ = -1;
  bool ok_ = false;
  int to_ = -1, from_ = -1, next_id_ = 1;
  std::string profile_, session_, buf_;
};

}  // namespace mimic::app
