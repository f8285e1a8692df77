// The third-party glTF/VRM readers (Khronos validator, three.js, @pixiv/three-vrm) for tests
// that load Mimic's exports with them: MIMIC_NODE_MODULES, else build/node/node_modules
// (scripts/node_tools.sh puts them there; a test installs them there itself when npm can reach
// its registry). Tests skip, saying why, when neither works.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include "run_mimic.h"

namespace mimic::test {

struct NodeTools {
  std::string modules;  // a node_modules folder holding the three packages, or empty
  std::string why_not;  // when empty: what is missing
};

inline bool node_tools_present(const std::filesystem::path& modules) {
  std::error_code ec;
  return std::filesystem::exists(modules / "gltf-validator" / "index.js", ec) &&
         std::filesystem::exists(modules / "three" / "examples" / "jsm" / "loaders" / "GLTFLoader.js", ec) &&
         std::filesystem::exists(modules / "@pixiv" / "three-vrm" / "lib" / "three-vrm.module.js", ec);
}

// Finds the tools, installing them once into build/node when they are missing (under a lock:
// several test programs may ask at once).
inline NodeTools node_tools() {
  if (const char* env = std::getenv("MIMIC_NODE_MODULES")) {
    if (node_tools_present(env)) return {env, ""};
    return {"", std::string("MIMIC_NODE_MODULES=") + env + " lacks gltf-validator, three or @pixiv/three-vrm"};
  }
  if (std::system("node --version >/dev/null 2>&1") != 0) return {"", "node is not installed"};
  std::error_code ec;
  const auto dir = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path().parent_path() / "node";
  if (ec) return {"", "cannot find the build folder"};
  const auto modules = dir / "node_modules";
  if (node_tools_present(modules)) return {modules.string(), ""};
  std::filesystem::create_directories(dir, ec);
  const std::string cmd = "flock '" + dir.string() + ".lock' bash '" MIMIC_SOURCE_DIR "/scripts/node_tools.sh' '" +
                          dir.string() + "' >'" + dir.string() + ".log' 2>&1";
  if (std::system(cmd.c_str()) != 0 || !node_tools_present(modules))
    return {"", "npm could not install the glTF validator and three-vrm (scripts/node_tools.sh; see " + dir.string() +
                    ".log)"};
  return {modules.string(), ""};
}

// Runs tests/support/gltf_check.mjs (mode "validate" or "vrm") on `file`: its JSON line.
inline Outcome gltf_check(const NodeTools& tools, const std::string& mode, const std::string& file) {
  return run_shell("node '" MIMIC_SOURCE_DIR "/tests/support/gltf_check.mjs' '" + tools.modules + "' " + mode + " '" +
                   file + "' 2>&1");
}

}  // namespace mimic::test
