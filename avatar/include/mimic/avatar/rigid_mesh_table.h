// The table of rigid meshes the program ships (the built-in body's head, hands and feet, meshed
// once from their primitives' field): its C++ source, for `mimic mesh --emit-rigid-meshes`.
#pragma once

#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

// The head, left hand and left foot of `model` meshed from their field at the model's skin
// counts, as the source of avatar/src/skin/rigid_mesh_table.cpp. Takes about a second.
Result<std::string> rigid_mesh_table(const BodyModel& model);

// One rigid part's closed mesh at the model's skin counts, in the frame of its joint in the zero
// posture, as a layout gets it: from the shipped table when it fits (carried onto the part's own
// primitives when they differ), else meshed from the field; or from the field only.
struct RigidPartMesh {
  std::vector<glm::vec3> positions_m;
  std::vector<uint32_t> triangles;  // counter-clockwise seen from outside
  bool shipped = false;             // came from the table
};
Result<RigidPartMesh> rigid_part_mesh(const BodyModel& model, RigidPart part, bool field_only = false);

}  // namespace mimic::avatar
