// RealtimeBody::shared: one body per (model, skeleton, options) while any avatar holds it.
#include <cstdio>
#include <map>
#include <mutex>
#include <string>

#include "mimic/avatar/realtime_skin.h"

namespace mimic::avatar {

namespace {

void append(std::string& key, const glm::vec3& v) {
  char buf[96];
  const int n = std::snprintf(buf, sizeof buf, "%a,%a,%a;", static_cast<double>(v.x), static_cast<double>(v.y),
                              static_cast<double>(v.z));
  key.append(buf, static_cast<size_t>(n));
}

// Everything the body is built from: the model's file form, the skeleton's joints, offsets,
// tips and DOFs (a calibrated skeleton differs from the model's), and the options.
std::string key_of(const BodyModel& model, const rig::Skeleton& skeleton, const RealtimeOptions& options) {
  std::string key = to_json(model, false);
  key += '|';
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    key += skeleton.joint_name(j) + ":" + std::to_string(skeleton.parent(j)) + ":";
    append(key, skeleton.offset_m(j));
    append(key, skeleton.tip_m(j));
  }
  for (const rig::Dof& d : skeleton.dofs()) {
    key += d.name + ":" + std::to_string(d.joint) + ":";
    append(key, d.axis);
    append(key, {d.min_rad, d.max_rad, d.rest_rad});
  }
  key += "|lod" + std::to_string(options.lod) + (options.rigid_parts ? "r" : "-") + (options.contact ? "c" : "-");
  return key;
}

}  // namespace

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::shared(const BodyModel& model, const rig::Skeleton& skeleton,
                                                                 const RealtimeOptions& options) {
  if (options.initial_pose) return create(model, skeleton, options);  // a caller's own pose: not shared
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<const RealtimeBody>> bodies;
  const std::string key = key_of(model, skeleton, options);
  std::lock_guard lock(mutex);
  if (auto it = bodies.find(key); it != bodies.end())
    if (auto body = it->second.lock()) return body;
  auto body = create(model, skeleton, options);
  if (!body) return body;
  for (auto it = bodies.begin(); it != bodies.end();) it = it->second.expired() ? bodies.erase(it) : std::next(it);
  bodies[key] = *body;
  return body;
}

}  // namespace mimic::avatar
