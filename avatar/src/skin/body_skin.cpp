// BodySkin's public face: creation, the stages in order, accessors.
#include "skin_impl.h"

namespace mimic::avatar {

// ---------------------------------------------------------------------------------------------

BodySkin::BodySkin(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BodySkin::BodySkin(BodySkin&&) noexcept = default;
BodySkin& BodySkin::operator=(BodySkin&&) noexcept = default;
BodySkin::~BodySkin() = default;

Result<BodySkin> BodySkin::create(const BodyModel& model, const SkinOptions& options) {
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  return create(model, *skeleton, options);
}

Result<BodySkin> BodySkin::create(const BodyModel& model, const rig::Skeleton& skeleton, const SkinOptions& options) {
  if (auto st = validate(model); !st) return tl::unexpected(st.error());
  if (options.subdivision < 0 || options.subdivision > 16)
    return fail(Errc::invalid_argument, "subdivision must be in [0, 16]");
  auto field = BodyField::create(model, skeleton);
  if (!field) return tl::unexpected(field.error());
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->skeleton = skeleton;
  impl->field = std::move(*field);
  if (auto st = impl->build(model); !st) return tl::unexpected(st.error());
  BodySkin skin(std::move(impl));
  skin.evaluate(skin.impl_->skeleton.zero_pose());
  return skin;
}

void BodySkin::stage_fk(const rig::Pose& pose) {
  const auto t0 = Clock::now();
  rig::forward_kinematics(impl_->skeleton, pose, impl_->world_from_joint);
  impl_->timings.fk_us = micros_since(t0);
}

void BodySkin::stage_deform(const rig::Pose& pose) {
  const auto t0 = Clock::now();
  impl_->field.update(impl_->world_from_joint, pose.dof_rad);
  for (Chain& c : impl_->chains) c.update(impl_->world_from_joint);
  impl_->timings.deform_us = micros_since(t0);
}

void BodySkin::stage_contours() {
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  m.stats = {};
  for (const Ring& r : m.rings) m.compute_ring(r);
  m.timings.contours_us = micros_since(t0);
}

void BodySkin::stage_bspline() {
  const auto t0 = Clock::now();
  impl_->evaluate_bspline();
  impl_->timings.bspline_us = micros_since(t0);
}

void BodySkin::stage_stitch() {
  const auto t0 = Clock::now();
  Impl& m = *impl_;
  auto& pos = m.mesh.positions;
  for (const Surface& s : m.surfaces) {
    if (!s.cap) continue;
    glm::vec3 c(0);
    for (uint32_t v : s.out_rows.back()) c += pos[v];
    pos[s.cap_vertex] = c / static_cast<float>(s.out_rows.back().size());
  }
  for (const RigidMesh& rm : m.rigid) {
    const rig::RigidTransform& w = m.world_from_joint[rm.joint];
    for (size_t i = 0; i < rm.local.size(); ++i) pos[rm.first_vertex + i] = w.apply(rm.local[i]);
    if (rm.toe_joint < 0) continue;
    const rig::RigidTransform& toes = m.world_from_joint[rm.toe_joint];
    for (size_t k = 0; k < rm.toe_vertex.size(); ++k) {
      glm::vec3& p = pos[rm.first_vertex + rm.toe_vertex[k]];
      p += rm.toe_weight[k] * (toes.apply(rm.toe_local[k]) - p);
    }
  }
  m.timings.stitch_us = micros_since(t0);
  if (m.options.normals) {
    const auto t1 = Clock::now();
    m.update_normals();
    m.timings.normals_us = micros_since(t1);
  }
}

void BodySkin::evaluate(const rig::Pose& pose) {
  stage_fk(pose);
  stage_deform(pose);
  stage_contours();
  stage_bspline();
  stage_stitch();
}

const Mesh& BodySkin::mesh() const { return impl_->mesh; }
const rig::Skeleton& BodySkin::skeleton() const { return impl_->skeleton; }
const BodyField& BodySkin::field() const { return impl_->field; }
const SkinTimings& BodySkin::timings() const { return impl_->timings; }
const SkinStats& BodySkin::stats() const { return impl_->stats; }

std::vector<BodySkin::ContourView> BodySkin::contours() const {
  std::vector<ContourView> out;
  for (const Ring& r : impl_->rings) {
    ContourView v;
    v.name = r.name;
    v.mask = r.mask;
    for (uint32_t s : r.slots) {
      v.points.push_back(impl_->ctrl[s]);
      v.ray_origins.push_back(impl_->ctrl_origin[s]);
      v.from_ray.push_back(impl_->ctrl_hit[s]);
    }
    if (r.kind == RingKind::driven) {
      const std::vector<uint32_t>& s_slots = impl_->rings[r.s_ring].slots;
      for (size_t j = 0; j < r.slots.size(); ++j) v.targets.push_back(impl_->driven_target(r, s_slots[j], r.goal[j]));
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace mimic::avatar
