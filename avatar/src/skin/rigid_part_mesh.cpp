// The rigid parts' meshes (rigid_part_mesh.h) and the cache of them.
#include "rigid_part_mesh.h"

#include "mimic/avatar/rigid_mesh_table.h"
#include "mimic/avatar/skin_lod.h"
#include "rigid_mesh_store.h"

#include <cstring>
#include <map>
#include <mutex>
#include <string>

namespace mimic::avatar::skin_detail {

size_t rigid_vertex_budget(RigidPart part, const SkinLayout& L) {
  const float share = part == RigidPart::head                                         ? kRigidShareHead
                      : part == RigidPart::left_hand || part == RigidPart::right_hand ? kRigidShareHand
                                                                                      : kRigidShareFoot;
  const float sphere = static_cast<float>(L.rigid_rings * L.rigid_points + 2);
  return std::max<size_t>(kRigidMinVertices, static_cast<size_t>(std::lround(share * sphere)));
}

namespace {

// The box, in the part's joint frame, that holds the part's solid: its primitives' supports
// (beyond which the field is zero), narrowed to the nodes of a coarse grid that are inside,
// with two coarse cells of margin.
std::pair<glm::vec3, glm::vec3> rigid_box(const BodyField& field, std::span<const uint16_t> cand,
                                          const rig::RigidTransform& local_from_world, const IsoField& f) {
  glm::vec3 lo(1e9f), hi(-1e9f);
  for (uint16_t i : cand) {
    const glm::vec3 c = local_from_world.apply(field.center(i));
    lo = glm::min(lo, c - field.bound_radius(i)), hi = glm::max(hi, c + field.bound_radius(i));
  }
  const float coarse = kRigidCoarseCell_m;
  glm::vec3 in_lo(1e9f), in_hi(-1e9f);
  for (float z = lo.z; z <= hi.z; z += coarse)
    for (float y = lo.y; y <= hi.y; y += coarse)
      for (float x = lo.x; x <= hi.x; x += coarse)
        if (f.value({x, y, z}) >= f.iso) in_lo = glm::min(in_lo, {x, y, z}), in_hi = glm::max(in_hi, {x, y, z});
  if (in_lo.x > in_hi.x) return {lo, hi};
  return {glm::max(lo, in_lo - 2.0f * coarse), glm::min(hi, in_hi + 2.0f * coarse)};
}

// What the mesh depends on, as bytes: the part, the joint's frame, every primitive of the part.
std::string field_key(RigidPart part, const BodyModel& model, const rig::RigidTransform& w) {
  std::string key;
  auto put = [&key](const auto& v) { key.append(reinterpret_cast<const char*>(&v), sizeof(v)); };
  put(part);
  // The mesh lies in the joint's frame: where the joint is matters only when some primitive
  // hangs off another joint (so a refitted skeleton does not mesh an unchanged hand again).
  const std::string* joint = nullptr;
  bool one_joint = true;
  for (const Primitive& p : model.primitives)
    if (p.part == part) {
      if (joint && *joint != p.joint) one_joint = false;
      joint = &p.joint;
    }
  if (!one_joint) put(w.translation), put(w.rotation);
  for (const Primitive& p : model.primitives)
    if (p.part == part) {
      key += p.joint;
      put(p.kind), put(p.state.semi_axes_m), put(p.state.center_m), put(p.state.orientation_rad);
      put(p.weight), put(p.influence);
      if (p.deformation) {  // the zero posture's state may lie between these
        key += p.deformation->dof;
        put(p.deformation->at_min.semi_axes_m), put(p.deformation->at_min.center_m);
        put(p.deformation->at_min.orientation_rad), put(p.deformation->at_max.semi_axes_m);
        put(p.deformation->at_max.center_m), put(p.deformation->at_max.orientation_rad), put(p.deformation->falloff);
      }
    }
  return key;
}

// The marching grid's meshes of the last few parts, and the simplified meshes of the last few
// parts and budgets. Cleared whole when full: a body's five parts at four LODs fit.
struct Cache {
  std::mutex mutex;
  std::map<std::string, std::shared_ptr<const IsoMesh>> fine;
  std::map<std::pair<std::string, size_t>, std::pair<IsoMesh, bool>> simplified;  // the mesh, shipped
};
constexpr size_t kFineKept = 10, kSimplifiedKept = 40;

Cache& cache() {
  static Cache c;
  return c;
}

std::shared_ptr<const IsoMesh> fine_mesh(RigidPart part, const BodyModel& model, const BodyField& field,
                                         std::span<const uint16_t> cand, const rig::RigidTransform& w,
                                         const std::string& key, const IsoField& f) {
  {
    std::lock_guard lock(cache().mutex);
    if (auto it = cache().fine.find(key); it != cache().fine.end()) return it->second;
  }
  float thinnest = 1e9f;
  for (const Primitive& p : model.primitives)
    if (p.part == part)
      thinnest = std::min({thinnest, p.state.semi_axes_m.x, p.state.semi_axes_m.y, p.state.semi_axes_m.z});
  const auto [lo, hi] = rigid_box(field, cand, w.inverse(), f);
  float cell = std::clamp(kRigidCellPerAxis * thinnest, kRigidMinCell_m, kRigidMaxCell_m);
  const glm::vec3 size = hi - lo;
  while ((size.x / cell + 3) * (size.y / cell + 3) * (size.z / cell + 3) > kRigidMaxNodes) cell *= 1.1f;
  auto m = std::make_shared<const IsoMesh>(march_tetrahedra(f, lo - cell, hi + cell, cell));
  std::lock_guard lock(cache().mutex);
  if (cache().fine.size() >= kFineKept) cache().fine.clear();
  cache().fine.emplace(key, m);
  return m;
}

}  // namespace

IsoMesh mesh_rigid_part(RigidPart part, const BodyModel& model, const BodyField& field, std::span<const uint16_t> cand,
                        const rig::RigidTransform& w, const SkinLayout& counts, RigidMeshSource source, bool* shipped) {
  const std::string key = field_key(part, model, w);
  const size_t budget = rigid_vertex_budget(part, counts);
  {
    std::lock_guard lock(cache().mutex);
    if (auto it = cache().simplified.find({key, budget});
        it != cache().simplified.end() && source == RigidMeshSource::any) {
      if (shipped) *shipped = it->second.second;
      return it->second.first;
    }
  }
  const IsoField f{[&](const glm::vec3& q) { return field.field_of(w.apply(q), cand); }, kIsoLevel};
  std::optional<IsoMesh> stored;
  if (source == RigidMeshSource::any) stored = rigid_mesh_from_store(part, model, f, budget, kRigidRelaxPasses);
  IsoMesh m = stored ? std::move(*stored) : *fine_mesh(part, model, field, cand, w, key, f);
  if (!stored) decimate(m, f, budget, kRigidRelaxPasses);
  std::lock_guard lock(cache().mutex);
  if (cache().simplified.size() >= kSimplifiedKept) cache().simplified.clear();
  if (source == RigidMeshSource::any)
    cache().simplified.emplace(std::make_pair(key, budget), std::make_pair(m, stored.has_value()));
  if (shipped) *shipped = stored.has_value();
  return m;
}

}  // namespace mimic::avatar::skin_detail

namespace mimic::avatar {

namespace {

// The part's mesh as a layout of `model` makes it (contour_layout.cpp add_rigid_part).
Result<RigidPartMesh> part_mesh(const BodyModel& model, RigidPart part, skin_detail::RigidMeshSource source) {
  using namespace skin_detail;
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto field = BodyField::create(model, *skeleton);
  if (!field) return tl::unexpected(field.error());
  std::vector<rig::RigidTransform> world_from_joint(static_cast<size_t>(skeleton->joint_count()));
  rig::forward_kinematics(*skeleton, skeleton->zero_pose(), world_from_joint);
  std::vector<uint16_t> cand(kMaxCandidates);
  cand.resize(static_cast<size_t>(field->candidates_of_part(part, cand)));
  int joint = -1;
  for (const Primitive& p : model.primitives)
    if (p.part == part) joint = skeleton->find_joint(p.joint);
  if (cand.empty() || joint < 0)
    return fail(Errc::invalid_argument, std::string("the body has no ") + rigid_part_name(part));
  RigidPartMesh out;
  IsoMesh m = mesh_rigid_part(part, model, *field, cand, world_from_joint[static_cast<size_t>(joint)], model.skin,
                              source, &out.shipped);
  out.positions_m = std::move(m.positions);
  out.triangles = std::move(m.triangles);
  return out;
}

}  // namespace

Result<RigidPartMesh> rigid_part_mesh(const BodyModel& model, RigidPart part, bool field_only) {
  return part_mesh(model, part, field_only ? skin_detail::RigidMeshSource::field : skin_detail::RigidMeshSource::any);
}

Result<std::string> rigid_mesh_table(const BodyModel& model) {
  using namespace skin_detail;
  std::vector<MeshToStore> meshes;
  // The right side is the left's mirror image, carried there at load (rigid_mesh_store.h). Each
  // LOD's budget is stored: simplifying at load, with the crossing checks, takes longer than the
  // rest of a layout.
  for (RigidPart part : {RigidPart::head, RigidPart::left_hand, RigidPart::left_foot})
    for (int lod = 0; lod < kSkinLodCount; ++lod) {
      const BodyModel at_lod = with_skin_lod(model, lod);
      const size_t budget = rigid_vertex_budget(part, at_lod.skin);
      if (!meshes.empty() && meshes.back().part == part && meshes.back().budget == budget) continue;
      auto m = part_mesh(at_lod, part, RigidMeshSource::field);
      if (!m) return tl::unexpected(m.error());
      if (m->positions_m.size() > UINT16_MAX)  // the table stores vertex indices in 16 bits
        return fail(Errc::invalid_argument, std::string("the ") + rigid_part_name(part) + "'s mesh has " +
                                                std::to_string(m->positions_m.size()) + " vertices, over 65,535");
      meshes.push_back({part, budget, IsoMesh{std::move(m->positions_m), std::move(m->triangles)}});
    }
  return rigid_mesh_table_source(model, meshes);
}

}  // namespace mimic::avatar
