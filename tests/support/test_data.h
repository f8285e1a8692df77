// Where tests find the shared third-party data and the built program.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace mimic::test {

// ../shared/data beside the checkout (CMake passes the path in MIMIC_SHARED_DATA).
inline std::string shared_data(const std::string& relative = "") {
  const char* env = std::getenv("MIMIC_SHARED_DATA");
  std::string root = env ? env : "../shared/data";
  return relative.empty() ? root : root + "/" + relative;
}

// MIMIC_BIN, else the `mimic` built beside the running test binary (both land in build/bin;
// CTest's ENVIRONMENT list does not always carry MIMIC_BIN through gtest_discover_tests).
inline std::string mimic_binary() {
  if (const char* env = std::getenv("MIMIC_BIN")) return env;
  std::error_code ec;
  const auto beside = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path() / "mimic";
  return !ec && std::filesystem::exists(beside, ec) ? beside.string() : "mimic";
}

// The repository's own test data (tests/data: golden logs, malformed BVH files).
inline std::filesystem::path repo_test_data(const std::string& relative = "") {
  const std::filesystem::path root = MIMIC_TEST_DATA_DIR;
  return relative.empty() ? root : root / relative;
}

inline const char* kShared_clips[] = {"02_04", "02_05", "02_06", "05_02", "06_04", "07_01", "09_11", "13_26"};

inline std::string clip_path(const std::string& id) { return shared_data("bvh/" + id + ".bvh"); }

}  // namespace mimic::test
