// The JSON chunk of a binary glTF (.glb, .vrm) file: {} when the file is not one.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace mimic::test {

inline nlohmann::json glb_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string b = ss.str();
  if (b.size() < 20 || b.compare(0, 4, "glTF") != 0) return {};
  uint32_t n = 0;
  std::memcpy(&n, b.data() + 12, 4);
  return nlohmann::json::parse(b.substr(20, n));
}

}  // namespace mimic::test
