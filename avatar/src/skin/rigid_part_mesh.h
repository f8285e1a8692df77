// The mesh of one rigid part (head, hand, foot) from its primitives' field, in its joint's frame
// (iso_mesh.h: marching tetrahedra, edge collapses to the part's vertex budget, relaxation).
#pragma once

#include <span>

#include "contour_layout_data.h"
#include "iso_mesh.h"

namespace mimic::avatar::skin_detail {

// The part's vertex budget at the layout's counts (rigid_rings × rigid_points times its share).
size_t rigid_vertex_budget(RigidPart part, const SkinLayout& counts);

// Where a rigid mesh comes from: the shipped table when it fits (rigid_mesh_store.h) else the
// field, or the field alone (to write the table).
enum class RigidMeshSource { any, field };

// The part's closed mesh, vertices in the frame of its joint (world_from_joint, the posture the
// field was updated to). A pure function of the part's primitives, that frame and the budget:
// the process keeps the last few results (meshing a field takes a few hundred milliseconds), so
// layouts of one body at each LOD, or built again, reuse them.
IsoMesh mesh_rigid_part(RigidPart part, const BodyModel& model, const BodyField& field,
                        std::span<const uint16_t> candidates, const rig::RigidTransform& world_from_joint,
                        const SkinLayout& counts, RigidMeshSource source = RigidMeshSource::any,
                        bool* shipped = nullptr);

}  // namespace mimic::avatar::skin_detail
