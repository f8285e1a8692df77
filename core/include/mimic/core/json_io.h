// Reading and writing Mimic's JSON files (body models, calibrations): a reader that keeps the path
// of what it reads, so every error says where it is ("body.json: $.skeleton.joints[3].dofs[0]:
// missing \"axis\""), and the rounding the writers use so round trips are exact.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

namespace mimic {

// Six decimals (micrometres, microdegrees) keep files readable and round trips exact.
inline double json_rounded(float v) { return std::round(static_cast<double>(v) * 1e6) / 1e6; }

inline nlohmann::json json_vec3(const glm::vec3& v) {
  return nlohmann::json::array({json_rounded(v.x), json_rounded(v.y), json_rounded(v.z)});
}

// The first error wins; later reads return their fallbacks, so a reader can go on to the end
// of a structure and the caller checks ok() once.
class JsonReader {
 public:
  using json = nlohmann::json;
  explicit JsonReader(std::string source) : source_(std::move(source)) {}

  [[nodiscard]] bool ok() const { return error_.empty(); }
  [[nodiscard]] const std::string& error() const { return error_; }

  void fail_at(const std::string& path, const std::string& what) {
    if (error_.empty()) error_ = source_ + ": " + path + ": " + what;
  }

  const json* member(const json& obj, const std::string& path, const char* key, bool required) {
    if (!obj.is_object()) {
      fail_at(path, "expected an object");
      return nullptr;
    }
    auto it = obj.find(key);
    if (it == obj.end()) {
      if (required) fail_at(path, std::string("missing \"") + key + "\"");
      return nullptr;
    }
    return &*it;
  }

  float number(const json& obj, const std::string& path, const char* key, float fallback, bool required = false) {
    const json* v = member(obj, path, key, required);
    if (!v) return fallback;
    if (!v->is_number()) {
      fail_at(path + "." + key, "expected a number");
      return fallback;
    }
    const double d = v->get<double>();
    if (!std::isfinite(d) || std::abs(d) > 3.0e38) {  // beyond a float: no undefined conversion
      fail_at(path + "." + key, "not a finite number a float can hold");
      return fallback;
    }
    return static_cast<float>(d);
  }

  int integer(const json& obj, const std::string& path, const char* key, int fallback) {
    const json* v = member(obj, path, key, false);
    if (!v) return fallback;
    if (!v->is_number_integer()) {
      fail_at(path + "." + key, "expected an integer");
      return fallback;
    }
    const int64_t n = v->get<int64_t>();
    if (n < INT32_MIN || n > INT32_MAX) {
      fail_at(path + "." + key, "integer out of range");
      return fallback;
    }
    return static_cast<int>(n);
  }

  std::string string(const json& obj, const std::string& path, const char* key, bool required,
                     const std::string& fallback = "") {
    const json* v = member(obj, path, key, required);
    if (!v) return fallback;
    if (!v->is_string()) {
      fail_at(path + "." + key, "expected a string");
      return fallback;
    }
    return v->get<std::string>();
  }

  glm::vec3 vec3(const json& obj, const std::string& path, const char* key, glm::vec3 fallback, bool required = false) {
    const json* v = member(obj, path, key, required);
    if (!v) return fallback;
    if (!v->is_array() || v->size() != 3) {
      fail_at(path + "." + key, "expected an array of 3 numbers");
      return fallback;
    }
    glm::vec3 out;
    for (int i = 0; i < 3; ++i) {
      const double d = (*v)[i].is_number() ? (*v)[i].get<double>() : NAN;
      if (!std::isfinite(d) || std::abs(d) > 3.0e38) {
        fail_at(path + "." + key + "[" + std::to_string(i) + "]", "expected a finite number");
        return fallback;
      }
      out[i] = static_cast<float>(d);
    }
    return out;
  }

 private:
  std::string source_;
  std::string error_;
};

}  // namespace mimic
