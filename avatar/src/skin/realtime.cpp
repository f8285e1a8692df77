// The realtime skin (realtime_skin.h), built once from a contour layout: contours ray-cast in the
// initial pose by the layout's implicit skin and measured in each ring's own frame
// (realtime_measure.cpp: coordinates, columns, muscle blocks, joint bands); realtime_deform.cpp
// moves them every frame.
#include <cstdio>

#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/texture_layout.h"
#include "mimic/core/clock.h"
#include "mimic/core/vertex_normals.h"
#include "band_sweep.h"
#include "realtime_data.h"

namespace mimic::avatar {

using namespace realtime_detail;

namespace {
using Data = RealtimeBody::Data;
}  // namespace

const char* skin_method_name(SkinMethod m) { return m == SkinMethod::full ? "full" : "realtime"; }

Result<SkinMethod> parse_skin_method(std::string_view name) {
  if (name == "full") return SkinMethod::full;
  if (name == "realtime") return SkinMethod::realtime;
  return fail(Errc::invalid_argument, "skin method must be full or realtime, not '" + std::string(name) + "'");
}

RealtimeBody::RealtimeBody(std::unique_ptr<Data> data) : data_(std::move(data)) {}
RealtimeBody::~RealtimeBody() = default;

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::create(const BodyModel& model,
                                                                 const RealtimeOptions& options) {
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  return create(model, *skeleton, options);
}

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::create(const BodyModel& model, const rig::Skeleton& skeleton,
                                                                 const RealtimeOptions& options) {
  if (options.lod < 0 || options.lod >= kSkinLodCount)
    return fail(Errc::out_of_range, "skin LOD must be in 0.." + std::to_string(kSkinLodCount - 1));
  auto layout = ContourLayout::build(with_skin_lod(model, options.lod), skeleton, {0, options.rigid_parts});
  if (!layout) return tl::unexpected(layout.error());
  return create(model, *layout, options);
}

namespace {

// The layout's rings as the per-frame loops read them (contiguous slots, goals gathered), each
// star ring linked to the star ring before it on its surface.
Status copy_rings(const ContourLayout::Data& L, Data& d) {
  for (const Ring& r : L.rings) {
    Data::RingOp op;
    op.kind = r.kind;
    op.first = r.slots.empty() ? 0 : r.slots.front();
    op.count = static_cast<uint32_t>(r.slots.size());
    for (size_t k = 0; k < r.slots.size(); ++k)
      if (r.slots[k] != op.first + k) return fail(Errc::unsupported, "ring slots are not contiguous");
    op.chain = r.chain;
    op.segment = r.segment;
    op.u = r.u;
    op.s_ring = r.s_ring;
    op.alpha = r.alpha;
    op.goal_first = static_cast<uint32_t>(d.goals.size());
    d.goals.insert(d.goals.end(), r.goal.begin(), r.goal.end());
    op.from = r.from;
    op.to = r.to;
    op.up_ring = r.up_ring;
    op.flip_up = r.flip_up;
    d.rings.push_back(op);
  }
  for (const Surface& s : L.surfaces) {
    int prev = -1;
    for (int id : s.rows) {
      if (id < 0 || L.rings[id].kind != RingKind::star) continue;
      d.rings[id].prev_star = prev;
      prev = id;
    }
  }
  return {};
}

// The star rings grouped by the chain segment they sit on (Data::FrameRun).
void group_frame_runs(Data& d) {
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    const Data::RingOp& r = d.rings[ri];
    if (r.kind != RingKind::star) continue;
    auto& runs = d.frame_runs;
    if (runs.empty() || runs.back().chain != r.chain || runs.back().segment != r.segment) {
      Data::FrameRun run;
      run.chain = r.chain, run.segment = r.segment, run.along_link = r.chain != kTorsoChain;
      run.first = static_cast<uint32_t>(d.run_rings.size());
      runs.push_back(run);
    }
    d.run_rings.push_back(static_cast<uint32_t>(ri));
    d.run_u.push_back(r.u);
    ++runs.back().count;
  }
  d.run_u.resize(d.run_u.size() + 8, 0.0f);
}

// Each star ring's rest centroid across the link (the band scale's centre).
void ring_centres(Data& d) {
  for (Data::RingOp& r : d.rings) {
    if (r.kind != RingKind::star || r.count < 3) continue;
    double a2 = 0, cx = 0, cy = 0;
    for (uint32_t k = 0; k < r.count; ++k) {
      const uint32_t i = r.first + k, j = r.first + (k + 1) % r.count;
      const double cr = double(d.lx[i]) * d.ly[j] - double(d.lx[j]) * d.ly[i];
      a2 += cr, cx += (d.lx[i] + d.lx[j]) * cr, cy += (d.ly[i] + d.ly[j]) * cr;
    }
    if (std::abs(a2) > 1e-12)
      r.centre = glm::vec2(static_cast<float>(cx / (3 * a2)), static_cast<float>(cy / (3 * a2)));
  }
}

// Caps, rigid parts and the planar contours' rows, from the layout's output topology.
void copy_caps_and_rigid(const ContourLayout::Data& L, Data& d) {
  for (const Surface& s : L.surfaces)
    if (s.cap) {
      const auto& last = s.out_rows.back();
      d.caps.push_back({s.cap_vertex, last.front(), static_cast<uint32_t>(last.size())});
    }
  for (const RigidMesh& rm : L.rigid) {
    d.rigid.push_back({rm.joint, rm.first_vertex, static_cast<uint32_t>(d.rigid_local.size()),
                       static_cast<uint32_t>(rm.local.size()), rm.toe_joint, static_cast<uint32_t>(d.toe_vertex.size()),
                       static_cast<uint32_t>(rm.toe_vertex.size())});
    d.rigid_local.insert(d.rigid_local.end(), rm.local.begin(), rm.local.end());
    for (uint32_t v : rm.toe_vertex) d.toe_vertex.push_back(rm.first_vertex + v);
    d.toe_weight.insert(d.toe_weight.end(), rm.toe_weight.begin(), rm.toe_weight.end());
    d.toe_local.insert(d.toe_local.end(), rm.toe_local.begin(), rm.toe_local.end());
  }
  for (const Surface& s : L.surfaces) {
    // The planar contours: star rings (a limb's loop and its boundary-driven rings blend the
    // torso into the limb and lie in no plane).
    ContourRows rows{s.name, {}};
    for (size_t r = 0; r < s.rows.size(); ++r)
      if (s.rows[r] >= 0 && L.rings[s.rows[r]].kind == RingKind::star) rows.rows.push_back(s.out_rows[r]);
    d.contour_rows.push_back(std::move(rows));
  }
}

// The eight-wide kernels read a ring's last chunk whole: eight entries of padding at the end.
void pad_for_kernels(Data& d) {
  for (std::vector<float>* v : {&d.lx, &d.ly, &d.lz, &d.lo_x, &d.lo_y, &d.hi_x, &d.hi_y, &d.muscle_data})
    v->resize(v->size() + 8, 0.0f);
  d.dh_lo.resize(d.dh_lo.size() + 8, -1e3f);
  d.dh_hi.resize(d.dh_hi.size() + 8, 1e3f);
}

std::vector<Chain> chains_at(const ContourLayout::Data& L, const rig::Pose& pose) {
  std::vector<rig::RigidTransform> w(static_cast<size_t>(L.skeleton.joint_count()));
  rig::forward_kinematics(L.skeleton, pose, w);
  std::vector<Chain> chains = L.chains;
  for (Chain& c : chains) c.update(w);
  return chains;
}

}  // namespace

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::create(const BodyModel& model, const ContourLayout& layout,
                                                                 const RealtimeOptions& options) {
  const ContourLayout::Data& L = layout.data();
  const rig::Skeleton& skeleton = L.skeleton;
  if (L.options.subdivision != 0)
    return fail(Errc::invalid_argument, "a realtime body needs a layout of subdivision 0");
  auto skin = ImplicitSkin::create(model, layout, true);
  if (!skin) return tl::unexpected(skin.error());
  const rig::Pose base = options.initial_pose ? *options.initial_pose : skeleton.zero_pose();
  if (base.dof_rad.size() != static_cast<size_t>(skeleton.dof_count()))
    return fail(Errc::invalid_argument, "initial pose has " + std::to_string(base.dof_rad.size()) +
                                            " DOF values, the skeleton " + std::to_string(skeleton.dof_count()));
  skin->evaluate(base);

  auto d = std::make_unique<Data>();
  d->skeleton = skeleton;
  d->lod = options.lod;
  // A skeleton fitted to a performer may not fill the body's primitives everywhere: rays that
  // miss are placed as the full method places them, and counted.
  d->missed_rays = skin->stats().missed_rays;
  const std::vector<Chain> chains = chains_at(L, base);
  d->chains = chains;
  if (auto st = copy_rings(L, *d); !st) return tl::unexpected(st.error());
  const RestContours rest{L, chains, skin->control_points()};
  std::vector<glm::vec3> local(rest.ctrl.size());
  measure_local(rest, *d, local);
  d->lx.resize(local.size()), d->ly.resize(local.size()), d->lz.resize(local.size());
  for (size_t k = 0; k < local.size(); ++k) d->lx[k] = local[k].x, d->ly[k] = local[k].y, d->lz[k] = local[k].z;
  measure_columns(rest, *d);
  measure_driven_columns(rest, *d);
  measure_loop_follows(rest, base, *d);
  {
    std::vector<rig::RigidTransform> w(static_cast<size_t>(skeleton.joint_count()));
    rig::forward_kinematics(skeleton, base, w);
    measure_sweeps(rest.ctrl, w, *d);
  }
  group_frame_runs(*d);
  ring_centres(*d);
  copy_caps_and_rigid(L, *d);
  d->rest_mesh = skin->mesh();
  auto weights = contour_skin_weights(layout);
  if (!weights) return tl::unexpected(weights.error());
  d->weights = std::move(*weights);
  d->texture = ::mimic::avatar::texture_layout(layout);
  measure_muscles(model, *skin, rest, base, *d);
  pad_for_kernels(*d);
  measure_joint_tips(rest, *d);
  if (auto st = calibrate_bands(rest, base, *d); !st) return tl::unexpected(st.error());
  if (options.contact) {
    std::vector<rig::RigidTransform> w(static_cast<size_t>(skeleton.joint_count()));
    rig::forward_kinematics(skeleton, base, w);
    // The boundary-driven bands' vertices, each with its neighbours along its ring and along
    // its column (towards the loop, towards S): the grid the contact's relaxation runs on.
    std::vector<BandNeighbours> band(d->rest_mesh.positions.size(), kNoBandNeighbours);
    std::vector<int32_t> band_follow(d->rest_mesh.positions.size(), -1);
    for (const Data::RingOp& r : d->rings) {
      if (r.kind != RingKind::driven) continue;
      const Data::RingOp* loopward = nullptr;  // the next ring of the band towards the loop (larger α)
      const Data::RingOp* sward = nullptr;     // … towards S
      for (const Data::RingOp& o : d->rings) {
        if (o.kind != RingKind::driven || o.s_ring != r.s_ring || &o == &r) continue;
        if (o.alpha > r.alpha && (!loopward || o.alpha < loopward->alpha)) loopward = &o;
        if (o.alpha < r.alpha && (!sward || o.alpha > sward->alpha)) sward = &o;
      }
      const uint32_t s_first = d->rings[static_cast<size_t>(r.s_ring)].first;
      for (uint32_t k = 0; k < r.count; ++k) {
        band[r.first + k] = {r.first + (k + r.count - 1) % r.count, r.first + (k + 1) % r.count,
                             loopward ? loopward->first + k : d->goals[r.goal_first + k],
                             sward ? sward->first + k : s_first + k};
        band_follow[r.first + k] = r.follow;
      }
    }
    d->contact = build_contact(model, skeleton, d->rest_mesh, w, band, band_follow);
  }
  return std::shared_ptr<const RealtimeBody>(new RealtimeBody(std::move(d)));
}

const rig::Skeleton& RealtimeBody::skeleton() const { return data_->skeleton; }
const Mesh& RealtimeBody::rest_mesh() const { return data_->rest_mesh; }
std::span<const JointInfluences> RealtimeBody::weights() const { return data_->weights; }
int RealtimeBody::lod() const { return data_->lod; }
const TextureLayout& RealtimeBody::texture_layout() const { return data_->texture; }
std::span<const ContourRows> RealtimeBody::contour_rows() const { return data_->contour_rows; }
size_t RealtimeBody::muscle_points() const { return data_->muscle_points; }
size_t RealtimeBody::muscle_terms() const { return data_->muscle_terms; }
int RealtimeBody::missed_rays() const { return data_->missed_rays; }
size_t RealtimeBody::contact_pairs() const { return data_->contact.pairs.size(); }
size_t RealtimeBody::contact_vertices() const { return data_->contact.vertices.size(); }

RealtimeBody::FrameWork RealtimeBody::work_per_frame(bool muscles) const {
  // Per point, as realtime_points.cpp does it (eight lanes or one, the same operations).
  constexpr double kStarRead = 9 * 4, kStarFlops = 55;           // coordinates, columns; scale … plane
  constexpr double kMuscleRead = 9 * 4, kMuscleFlops = 15;       // one block: offset, to_min, to_max
  constexpr double kDrivenRead = 3 * 12 + 8, kDrivenFlops = 35;  // S, G (gathered), offset, index, 1/len²
  // Swept (band_sweep.h): the column's polar form (shared by the band's rings) and its offset;
  // the turn's sine and cosine, the blend, the plane.
  constexpr double kSweptRead = 10 * 4, kSweptFlops = 60;
  constexpr double kArcRead = 12, kArcFlops = 21;
  constexpr double kRigidRead = 12, kRigidFlops = 18;
  const Data& d = *data_;
  FrameWork w;
  for (const Data::RingOp& r : d.rings) {
    const double n = r.count;
    switch (r.kind) {
      case RingKind::star:
        w.bytes_read += n * kStarRead;
        w.flops += n * kStarFlops;
        if (muscles) w.bytes_read += n * r.muscle_count * kMuscleRead, w.flops += n * r.muscle_count * kMuscleFlops;
        break;
      case RingKind::driven:
        if (r.sweep >= 0)
          w.bytes_read += n * kSweptRead, w.flops += n * kSweptFlops;
        else
          w.bytes_read += n * kDrivenRead, w.flops += n * kDrivenFlops;
        break;
      case RingKind::arc: w.bytes_read += n * kArcRead, w.flops += n * kArcFlops; break;
    }
    w.bytes_written += n * 12;
  }
  for (const Data::Cap& c : d.caps) w.bytes_read += c.count * 12.0, w.flops += c.count * 3.0, w.bytes_written += 12;
  for (const Data::Rigid& rg : d.rigid)
    w.bytes_read += rg.count * kRigidRead, w.flops += rg.count * kRigidFlops, w.bytes_written += rg.count * 12.0;
  return w;
}

size_t RealtimeBody::shared_bytes() const {
  const Data& d = *data_;
  size_t follow_bytes = 0;
  for (const skin_detail::LoopFollow& lf : d.follows) follow_bytes += lf.heap_bytes();
  size_t b = sizeof(Data) + d.rings.capacity() * sizeof(Data::RingOp) + d.goals.capacity() * 4 +
             (d.lx.capacity() + d.ly.capacity() + d.lz.capacity()) * 4 +
             (d.lo_x.capacity() + d.lo_y.capacity() + d.hi_x.capacity() + d.hi_y.capacity() + d.dh_lo.capacity() +
              d.dh_hi.capacity() + d.column_inv_len2.capacity() + d.tip_radius2.capacity()) *
                 4 +
             d.muscle_blocks.capacity() * sizeof(Data::MuscleBlock) + d.muscle_data.capacity() * 4 +
             d.frame_runs.capacity() * sizeof(Data::FrameRun) + (d.run_rings.capacity() + d.run_u.capacity()) * 4 +
             d.rigid_local.capacity() * sizeof(glm::vec3) + d.weights.capacity() * sizeof(JointInfluences) +
             d.toe_vertex.capacity() * 4 + d.toe_weight.capacity() * 4 + d.toe_local.capacity() * sizeof(glm::vec3) +
             d.texture.source.capacity() * 4 + d.texture.uv.capacity() * sizeof(glm::vec2) +
             d.texture.indices.capacity() * 4 + d.follows.capacity() * sizeof(skin_detail::LoopFollow) + follow_bytes +
             d.band_in_s.capacity() * sizeof(glm::mat3) + d.band_twist_rest.capacity() * 4 + d.contact.heap_bytes();
  for (const Data::Band& band : d.bands)
    b += sizeof(Data::Band) + (band.bend_rad.capacity() + band.scale[0].capacity() + band.scale[1].capacity()) * 4;
  b += d.rest_mesh.positions.capacity() * sizeof(glm::vec3) + d.rest_mesh.normals.capacity() * sizeof(glm::vec3) +
       d.rest_mesh.indices.capacity() * 4;
  return b;
}

// ---------------------------------------------------------------------------------------------
// Per avatar

struct RealtimeSkin::State : realtime_detail::State {
  using realtime_detail::State::State;
};

RealtimeSkin::RealtimeSkin(std::shared_ptr<const RealtimeBody> body)
    : body_(std::move(body)), state_(std::make_unique<State>(body_->data())) {}
RealtimeSkin::RealtimeSkin(RealtimeSkin&&) noexcept = default;
RealtimeSkin& RealtimeSkin::operator=(RealtimeSkin&&) noexcept = default;
RealtimeSkin::~RealtimeSkin() = default;

const RealtimeTimings& RealtimeSkin::timings() const { return state_->timings; }
size_t RealtimeSkin::contact_moved() const { return state_->contact.moved; }

size_t RealtimeSkin::instance_bytes() const { return sizeof(*this) + sizeof(State) + state_->heap_bytes(); }

void RealtimeSkin::use_scalar_reference(bool scalar) { state_->vectorised = !scalar; }

void RealtimeSkin::evaluate(const rig::Pose& pose, std::span<glm::vec3> pos, std::span<glm::vec3> normals, bool muscles,
                            bool contact) {
  const RealtimeBody::Data& d = body_->data();
  if (pos.size() < d.rest_mesh.positions.size() || pose.dof_rad.size() != static_cast<size_t>(d.skeleton.dof_count()))
    return;  // a caller's sizing error; documented sizes
  const bool with_contact = contact && !d.contact.empty();
  deform(d, *state_, pose, pos, muscles, with_contact);
  state_->contact.moved = 0;
  if (with_contact) {
    const double t1 = steady_now_s();
    apply_contact(d.contact, state_->contact, state_->follow_fade, pos);
    state_->timings.contact_us = (steady_now_s() - t1) * 1e6;
  } else {
    state_->timings.contact_us = 0;
  }
  const double t2 = steady_now_s();
  if (normals.size() >= pos.size())
    vertex_normals(pos.first(d.rest_mesh.positions.size()), d.rest_mesh.indices, normals);
  state_->timings.normals_us = normals.size() >= pos.size() ? (steady_now_s() - t2) * 1e6 : 0.0;
}

}  // namespace mimic::avatar
