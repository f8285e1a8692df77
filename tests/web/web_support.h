// The browser viewer's tests: headless Chromium loading the page `mimic run --http` serves, and
// reading the report the page writes about itself into its DOM (#stats, JSON).
#pragma once

#include <filesystem>
#include <string>

// The Chromium driver is the one `mimic bench --section web` uses (apps/mimic).
#include "headless_chromium.h"
#include "test_data.h"

namespace mimic::test::web {

inline std::string chromium() { return ::mimic::app::chromium_path(); }

using Chromium = ::mimic::app::HeadlessChromium;

// Why the browser tests cannot run here (empty: they can).
inline std::string skip_reason() {
  if (chromium().empty()) return "no Chromium (Debian's chromium; scripts/setup.sh installs it)";
  const auto wasm = std::filesystem::path(mimic_binary()).parent_path().parent_path() / "web" / "mimic_web.wasm";
  if (!std::filesystem::exists(wasm))
    return "no WebAssembly skin at " + wasm.string() + " (built only where Emscripten's emcmake is installed)";
  return "";
}

// The page's address from `mimic run`'s first line ("...; browser viewer on http://H:P/").
inline std::string page_url(const std::string& first_line) {
  const std::string key = "browser viewer on ";
  const size_t at = first_line.find(key);
  if (at == std::string::npos) return "";
  const size_t end = first_line.find(';', at);
  return first_line.substr(at + key.size(), end == std::string::npos ? std::string::npos : end - at - key.size());
}

}  // namespace mimic::test::web
