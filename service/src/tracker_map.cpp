#include "tracker_map.h"

#include "mimic/solver/sensor_layout.h"

namespace mimic::service {

Result<solver::SensorBinding> binding_on(const std::string& name, uint16_t sensor, const rig::Skeleton& skeleton) {
  for (const char* layout_name : {"11", "all"}) {
    auto layout = solver::standard_layout(layout_name, skeleton);
    if (!layout) continue;
    for (solver::SensorBinding b : layout->bindings)
      if (b.name == name || b.segment == name) {
        b.sensor = sensor;
        return b;
      }
  }
  if (skeleton.find_joint(name) >= 0) {
    solver::SensorBinding b;
    b.sensor = sensor;
    b.name = b.segment = name;
    return b;
  }
  return fail(Errc::not_found, "no segment '" + name +
                                   "' (names: head, pelvis, chest, l_hand, l_foot, l_upper_arm, "
                                   "l_thigh, the r_ ones, or a joint name)");
}

std::vector<solver::SensorMount> mounts_of(const solver::SensorLayout& layout) {
  std::vector<solver::SensorMount> mounts;
  for (const auto& b : layout.bindings) {
    solver::SensorMount m{b.sensor, b.segment, {}};
    m.segment_from_sensor.translation = b.placement_m;
    mounts.push_back(std::move(m));
  }
  return mounts;
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start < text.size()) {
    size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    if (comma > start) out.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

}  // namespace mimic::service
