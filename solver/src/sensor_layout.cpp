#include "mimic/solver/sensor_layout.h"

namespace mimic::solver {

namespace {

glm::vec3 mirror(glm::vec3 p) { return {-p.x, p.y, p.z}; }

void add(SensorLayout& l, std::string name, std::string segment, glm::vec3 placement) {
  l.bindings.push_back(
      SensorBinding{static_cast<uint16_t>(l.bindings.size()), std::move(name), std::move(segment), placement});
}

void add_pair(SensorLayout& l, const std::string& part, const std::string& joint, glm::vec3 left) {
  add(l, "l_" + part, "l_" + joint, left);
  add(l, "r_" + part, "r_" + joint, mirror(left));
}

}  // namespace

std::vector<std::string> standard_layout_names() { return {"3", "6", "11", "all"}; }

Result<SensorLayout> standard_layout(std::string_view name, const rig::Skeleton& skeleton) {
  SensorLayout l;
  l.name = std::string(name);
  if (name == "all") {
    for (int j = 0; j < skeleton.joint_count(); ++j) {
      add(l, skeleton.joint_name(j), skeleton.joint_name(j), 0.5f * skeleton.tip_m(j));
      l.bindings.back().link_fraction = 0.5f;
    }
  } else if (name == "3" || name == "6" || name == "11") {
    // Top of the head, back of the hand, sacrum, instep, outer upper arm, front of the thigh,
    // sternum: places a strap holds still on most people.
    add(l, "head", "head", {0.0f, 0.160f, -0.020f});
    add_pair(l, "hand", "wrist", {0.080f, 0.030f, 0.0f});
    if (name != "3") {
      add(l, "pelvis", "pelvis", {0.0f, 0.020f, -0.120f});
      add_pair(l, "foot", "ankle", {0.0f, -0.010f, 0.080f});
    }
    if (name == "11") {
      add_pair(l, "upper_arm", "shoulder", {0.120f, 0.050f, 0.0f});
      add_pair(l, "thigh", "hip", {0.0f, -0.200f, 0.080f});
      add(l, "chest", "spine_upper", {0.0f, 0.100f, 0.110f});
    }
  } else {
    return fail(Errc::not_found, "unknown sensor layout '" + std::string(name) + "' (known: 3, 6, 11, all)");
  }
  for (const auto& b : l.bindings)
    if (skeleton.find_joint(b.segment) < 0)
      return fail(Errc::not_found, "sensor layout '" + l.name + "': the skeleton has no segment '" + b.segment +
                                       "' for sensor '" + b.name + "'");
  return l;
}

}  // namespace mimic::solver
