// Calibration as JSON: the fitted skeleton, the sensor mounts and the capture's statistics.
#include <filesystem>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <nlohmann/json.hpp>

#include "mimic/core/file.h"
#include "mimic/core/finite.h"
#include "mimic/solver/calibration.h"

namespace mimic::solver {

using rig::Skeleton;

namespace {

using nlohmann::json;

json vec(const glm::vec3& v) { return json::array({v.x, v.y, v.z}); }

// Numbers as floats without undefined conversions: a value beyond float's range is refused.
bool read_float(const json& j, float& out) {
  if (!j.is_number()) return false;
  const double v = j.get<double>();
  if (!std::isfinite(v) || std::abs(v) > 3.0e38) return false;
  out = static_cast<float>(v);
  return true;
}

// A member of the expected type, or the default: never an exception on a wrong type.
std::string string_or(const json& j, const char* key, const std::string& fallback) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : fallback;
}

bool read_vec(const json& j, glm::vec3& out) {
  if (!j.is_array() || j.size() != 3) return false;
  for (int i = 0; i < 3; ++i) {
    if (!j[i].is_number()) return false;
    if (!read_float(j[i], out[i])) return false;
  }
  return all_finite(out);
}

}  // namespace

std::string calibration_to_json(const Calibration& cal) {
  json j;
  j["format"] = "mimic-calibration";
  j["version"] = 1;
  j["pose"] = calibration_pose_name(cal.pose);
  j["height_m"] = cal.height_m;
  j["heading_deg"] = cal.heading_deg;
  j["floor_y_m"] = cal.floor_y_m;
  j["standing_root_y_m"] = cal.standing_root_y_m;
  if (!cal.body.empty()) j["body"] = cal.body;
  j["capture"] = {{"samples", cal.samples},
                  {"duration_s", cal.duration_s},
                  {"max_motion_mm", cal.max_motion_mm},
                  {"max_motion_deg", cal.max_motion_deg}};
  json sensors = json::array();
  for (const auto& sc : cal.sensors) {
    const glm::quat& q = sc.segment_from_sensor.rotation;
    sensors.push_back({{"sensor", sc.sensor},
                       {"name", sc.name},
                       {"segment", sc.segment},
                       {"translation_m", vec(sc.segment_from_sensor.translation)},
                       {"rotation_wxyz", json::array({q.w, q.x, q.y, q.z})}});
  }
  j["sensors"] = sensors;
  json joints = json::array();
  for (const auto& jd : cal.skeleton.joints) {
    json dofs = json::array();
    for (const auto& f : jd.dofs)
      dofs.push_back({{"name", f.name},
                      {"axis", vec(f.axis)},
                      {"min_deg", glm::degrees(f.min_rad)},
                      {"max_deg", glm::degrees(f.max_rad)},
                      {"rest_deg", glm::degrees(f.rest_rad)}});
    joints.push_back({{"name", jd.name},
                      {"parent", jd.parent},
                      {"offset_m", vec(jd.offset_m)},
                      {"tip_m", vec(jd.tip_m)},
                      {"dofs", dofs}});
  }
  j["skeleton"] = {{"joints", joints}};
  return j.dump(1) + "\n";
}

Result<Calibration> calibration_from_json(std::string_view text) {
  const json j = json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded()) return fail(Errc::parse_error, "calibration: not valid JSON");
  auto bad = [](const std::string& what) { return fail(Errc::parse_error, "calibration: " + what); };
  if (!j.is_object() || string_or(j, "format", "") != "mimic-calibration")
    return bad("not a mimic-calibration file (\"format\")");
  if (!j.contains("version") || !j["version"].is_number_integer() || j["version"].get<int64_t>() != 1)
    return bad("unsupported version (expected 1)");
  Calibration cal;
  if (j.contains("pose") && !j["pose"].is_string()) return bad("\"pose\" must be tpose or npose");
  auto pose = parse_calibration_pose(string_or(j, "pose", "tpose"));
  if (!pose) return bad("\"pose\" must be tpose or npose");
  cal.pose = *pose;
  if (j.contains("height_m")) read_float(j["height_m"], cal.height_m);
  if (j.contains("heading_deg")) read_float(j["heading_deg"], cal.heading_deg);
  if (j.contains("floor_y_m")) read_float(j["floor_y_m"], cal.floor_y_m);
  if (j.contains("standing_root_y_m")) read_float(j["standing_root_y_m"], cal.standing_root_y_m);
  if (j.contains("body")) {
    if (!j["body"].is_string() || j["body"].get<std::string>().empty())
      return bad("\"body\" must be the path of a body model file");
    cal.body = j["body"].get<std::string>();
  }
  if (j.contains("capture") && j["capture"].is_object()) {
    const json& c = j["capture"];
    if (c.contains("samples") && c["samples"].is_number_integer()) {
      const int64_t n = c["samples"].get<int64_t>();
      cal.samples = static_cast<int>(std::clamp<int64_t>(n, 0, INT32_MAX));
    }
    if (c.contains("duration_s") && c["duration_s"].is_number()) cal.duration_s = c["duration_s"].get<double>();
    if (c.contains("max_motion_mm")) read_float(c["max_motion_mm"], cal.max_motion_mm);
    if (c.contains("max_motion_deg")) read_float(c["max_motion_deg"], cal.max_motion_deg);
  }
  if (!j.contains("skeleton") || !j["skeleton"].is_object() || !j["skeleton"].contains("joints") ||
      !j["skeleton"]["joints"].is_array())
    return bad("missing \"skeleton\".\"joints\"");
  int index = 0;
  for (const json& jj : j["skeleton"]["joints"]) {
    const std::string where = "skeleton joint " + std::to_string(index++);
    if (!jj.is_object() || !jj.contains("name") || !jj["name"].is_string()) return bad(where + ": missing \"name\"");
    rig::JointDesc jd;
    jd.name = jj["name"].get<std::string>();
    if (jj.contains("parent") && jj["parent"].is_string()) jd.parent = jj["parent"].get<std::string>();
    if (!jj.contains("offset_m") || !read_vec(jj["offset_m"], jd.offset_m))
      return bad(where + " (" + jd.name + "): bad \"offset_m\"");
    if (!jj.contains("tip_m") || !read_vec(jj["tip_m"], jd.tip_m))
      return bad(where + " (" + jd.name + "): bad \"tip_m\"");
    if (jj.contains("dofs")) {
      if (!jj["dofs"].is_array()) return bad(where + " (" + jd.name + "): \"dofs\" is not an array");
      for (const json& fj : jj["dofs"]) {
        rig::DofDesc f;
        if (!fj.is_object() || !fj.contains("name") || !fj["name"].is_string() || !fj.contains("axis") ||
            !read_vec(fj["axis"], f.axis) || !fj.contains("min_deg") || !fj["min_deg"].is_number() ||
            !fj.contains("max_deg") || !fj["max_deg"].is_number())
          return bad(where + " (" + jd.name + "): a DOF needs name, axis, min_deg, max_deg");
        f.name = fj["name"].get<std::string>();
        float min_deg = 0, max_deg = 0, rest_deg = 0;
        if (!read_float(fj["min_deg"], min_deg) || !read_float(fj["max_deg"], max_deg) ||
            (fj.contains("rest_deg") && !read_float(fj["rest_deg"], rest_deg)))
          return bad(where + " (" + jd.name + "): DOF '" + f.name + "' has a limit that is not a finite number");
        f.min_rad = glm::radians(min_deg);
        f.max_rad = glm::radians(max_deg);
        f.rest_rad = glm::radians(rest_deg);
        jd.dofs.push_back(f);
      }
    }
    cal.skeleton.joints.push_back(std::move(jd));
  }
  if (auto s = Skeleton::build(cal.skeleton); !s) return bad("skeleton: " + s.error().message);
  if (!j.contains("sensors") || !j["sensors"].is_array()) return bad("missing \"sensors\"");
  index = 0;
  for (const json& sj : j["sensors"]) {
    const std::string where = "sensor entry " + std::to_string(index++);
    SensorCalibration sc;
    if (!sj.is_object() || !sj.contains("sensor") || !sj["sensor"].is_number_unsigned() ||
        sj["sensor"].get<unsigned>() > 65535)
      return bad(where + ": bad \"sensor\" id");
    sc.sensor = static_cast<uint16_t>(sj["sensor"].get<unsigned>());
    if (!sj.contains("segment") || !sj["segment"].is_string()) return bad(where + ": missing \"segment\"");
    sc.segment = sj["segment"].get<std::string>();
    sc.name = string_or(sj, "name", sc.segment);
    if (!sj.contains("translation_m") || !read_vec(sj["translation_m"], sc.segment_from_sensor.translation))
      return bad(where + ": bad \"translation_m\"");
    const json& q = sj.contains("rotation_wxyz") ? sj["rotation_wxyz"] : json();
    if (!q.is_array() || q.size() != 4 || !q[0].is_number() || !q[1].is_number() || !q[2].is_number() ||
        !q[3].is_number())
      return bad(where + ": bad \"rotation_wxyz\"");
    float qw = 0, qx = 0, qy = 0, qz = 0;
    if (!read_float(q[0], qw) || !read_float(q[1], qx) || !read_float(q[2], qy) || !read_float(q[3], qz))
      return bad(where + ": \"rotation_wxyz\" is not four finite numbers");
    glm::quat r(qw, qx, qy, qz);
    if (!(glm::dot(r, r) > 0.5f && glm::dot(r, r) < 2.0f))
      return bad(where + ": \"rotation_wxyz\" is not a unit quaternion");
    sc.segment_from_sensor.rotation = glm::normalize(r);
    cal.sensors.push_back(sc);
  }
  return cal;
}

Status save_calibration(const std::string& path, const Calibration& cal) {
  return write_file_atomic(path, calibration_to_json(cal));
}

Result<Calibration> load_calibration(const std::string& path) {
  auto text = read_file(path);
  if (!text) return tl::unexpected(text.error());
  auto cal = calibration_from_json(*text);
  if (!cal) return fail(cal.error().code, path + ": " + cal.error().message);
  return cal;
}

std::string calibration_body_path(const std::string& calibration_path, const Calibration& cal) {
  if (cal.body.empty()) return {};
  const std::filesystem::path body(cal.body);
  if (body.is_absolute()) return cal.body;
  return (std::filesystem::path(calibration_path).parent_path() / body).lexically_normal().string();
}

}  // namespace mimic::solver
