// The realtime skin (realtime_skin.h): contours measured once in each ring's own frame, moved
// every frame by the ring configurations of the current pose.
#include "mimic/avatar/realtime_skin.h"

#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/texture_layout.h"
#include "skin_impl.h"

namespace mimic::avatar {

namespace {

// The frame a ring's points are measured in this frame: the ring plane's orthonormal axes
// (front, left, normal) and, for star rings, the link the ring cuts.
struct Frame {
  glm::vec3 origin{0.0f}, x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
  float x_scale = 1.0f;  // bridges: the half chord, so the arc stretches with its ends
  // Star rings: a point is kept as its projection along the link onto the plane across the link
  // (px, py), and put back on the ring plane along the link. A plane tilted against its link
  // (a bisector plane at a bent joint) then cuts the limb obliquely, stretched by 1/cos of the
  // tilt as the limb's own section would be, instead of carrying the straight section over.
  glm::vec3 axis{0, 0, 1}, px{1, 0, 0}, py{0, 1, 0};
  float along_per_normal = 1.0f;  // 1 / cos(link, normal), bounded

  glm::vec3 to_world(const glm::vec3& l) const { return origin + (l.x * x_scale) * x + l.y * y + l.z * z; }
  glm::vec3 to_local(const glm::vec3& p) const {
    const glm::vec3 d = p - origin;
    return {glm::dot(d, x) / x_scale, glm::dot(d, y), glm::dot(d, z)};
  }
  // (px, py, height) ↔ point: p = o + q + (height − q·n)·along_per_normal·axis, q = x·px + y·py.
  glm::vec3 star_to_world(const glm::vec3& l) const {
    const glm::vec3 q = l.x * px + l.y * py;
    return origin + q + ((l.z - glm::dot(q, z)) * along_per_normal) * axis;
  }
  glm::vec3 star_to_local(const glm::vec3& p) const {
    const glm::vec3 d = p - origin;
    const float h = glm::dot(d, axis);
    const glm::vec3 q = d - h * axis;
    return {glm::dot(q, px), glm::dot(q, py), h / along_per_normal + glm::dot(q, z)};
  }
};

// Most a ring's section is stretched along its tilt (1/0.3, a ring tilted 72.5° against its
// link): beyond, a sharply bent joint would push its outer side far out. The inner side is held
// by the crease (below); 0.3 keeps the volume of an elbow flexed 150° within 0.1% of the body's.
constexpr float kMinLinkCos = 0.3f;
constexpr int kTorsoChain = 0;  // layout.cpp builds the torso chain first

// `along_link`: limbs and neck, round their links; the torso is no cylinder round its short
// spine links, so its rings keep their section in their plane (axis = normal).
Frame star_frame(const Chain& c, int segment, float u, bool along_link) {
  const Plane p = ring_plane(c, segment, u);
  Frame f{p.origin, p.front, p.left, p.normal, 1.0f};
  const int a = segment, b = std::min<int>(segment + 1, static_cast<int>(c.point.size()) - 1);
  f.axis = along_link ? safe_normalize(c.point[b] - c.point[a], p.normal) : p.normal;
  if (glm::dot(f.axis, p.normal) < 0.0f) f.axis = -f.axis;
  const float cos_tilt = glm::dot(f.axis, p.normal);
  if (cos_tilt < kMinLinkCos) {
    // Tilted past the bound: project along an axis turned towards the normal until it is at
    // the bound, so the points still land on the ring's plane.
    const glm::vec3 tilt = safe_normalize(f.axis - cos_tilt * p.normal, p.front);
    f.axis = kMinLinkCos * p.normal + std::sqrt(1.0f - kMinLinkCos * kMinLinkCos) * tilt;
  }
  f.along_per_normal = 1.0f / glm::dot(f.axis, p.normal);
  f.px = safe_normalize(p.front - glm::dot(p.front, f.axis) * f.axis, p.left);
  f.py = glm::cross(f.axis, f.px);
  return f;
}

// A bridge's frame from its end points and the normal of the ring it leaves (as ray_contours.cpp
// sets up its half star).
Frame arc_frame(const glm::vec3& from, const glm::vec3& to, const glm::vec3& base_normal, bool flip_up) {
  Frame f;
  f.origin = 0.5f * (from + to);
  const glm::vec3 half = from - f.origin;
  f.x_scale = std::max(glm::length(half), 1e-6f);
  f.x = safe_normalize(half, {0, 0, 1});
  glm::vec3 up = flip_up ? -base_normal : base_normal;
  f.y = safe_normalize(up - glm::dot(up, f.x) * f.x, {0, 1, 0});
  f.z = glm::cross(f.x, f.y);
  return f;
}

float falloff_of(Falloff f, float t) {
  switch (f) {
    case Falloff::linear: return t;
    case Falloff::parabolic: return t * t;
    case Falloff::hyperbolic: return std::sqrt(t);
  }
  return t;
}

// (weight towards θmin, weight towards θmax) of a DOF value, as the primitives interpolate.
glm::vec2 muscle_weights(float theta, float theta0, float theta_min, float theta_max, Falloff falloff) {
  if (theta >= theta0) {
    const float span = theta_max - theta0;
    const float t = span > 1e-6f ? std::clamp((theta - theta0) / span, 0.0f, 1.0f) : 0.0f;
    return {0.0f, falloff_of(falloff, t)};
  }
  const float span = theta0 - theta_min;
  const float t = span > 1e-6f ? std::clamp((theta0 - theta) / span, 0.0f, 1.0f) : 0.0f;
  return {falloff_of(falloff, t), 0.0f};
}

using Clock = std::chrono::steady_clock;

}  // namespace

struct RealtimeBody::Data {
  Skeleton skeleton;
  int lod = 0;
  std::vector<Chain> chains;  // nodes; the per-frame members are each avatar's
  struct RingOp {
    RingKind kind = RingKind::star;
    uint32_t first = 0, count = 0;  // the ring's slots (contiguous) = its vertices
    int chain = -1, segment = 0;    // star
    float u = 0;
    int prev_star = -1;             // star: the star ring before it on its surface
    int s_ring = -1;                // driven
    float alpha = 0;
    uint32_t goal_first = 0;        // driven: offset in `goals`
    uint32_t from = 0, to = 0;      // arc
    int up_ring = -1;
    bool flip_up = false;
  };
  std::vector<RingOp> rings;
  std::vector<uint32_t> goals;
  std::vector<glm::vec3> local;  // per slot, in its ring's frame
  struct MuscleDof {
    int dof = -1;
    float theta0 = 0, theta_min = 0, theta_max = 0;
    Falloff falloff = Falloff::linear;
  };
  std::vector<MuscleDof> muscle_dofs;
  struct MuscleTerm {
    uint32_t slot = 0;
    uint32_t dof = 0;  // index in muscle_dofs
    glm::vec3 offset{0.0f}, to_min{0.0f}, to_max{0.0f};  // local += offset + w.x·to_min + w.y·to_max
  };
  std::vector<MuscleTerm> terms;  // sorted by slot
  size_t muscle_points = 0;
  int missed_rays = 0;
  struct Cap {
    uint32_t vertex = 0, first = 0, count = 0;
  };
  std::vector<Cap> caps;
  struct Rigid {
    int joint = -1;
    uint32_t first_vertex = 0, first_local = 0, count = 0;
  };
  std::vector<Rigid> rigid;
  std::vector<glm::vec3> rigid_local;
  Mesh rest_mesh;
  std::vector<JointInfluences> weights;
  TextureLayout texture;
  std::vector<ContourRows> contour_rows;
};

namespace {

// Each slot's coordinates in its ring's frame, for the skin's current contours (the inverse of
// what RealtimeSkin::evaluate does).
void measure_local(const std::vector<Chain>& chains, const std::vector<Ring>& rings, const std::vector<glm::vec3>& ctrl,
                   const RealtimeBody::Data& d, std::vector<glm::vec3>& local) {
  std::vector<Frame> frames(d.rings.size());
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    const auto& r = d.rings[ri];
    const Ring& src = rings[ri];
    Frame f;
    switch (r.kind) {
      case RingKind::star:
        f = star_frame(chains[r.chain], src.segment, src.u, r.chain != kTorsoChain);
        for (uint32_t k = 0; k < r.count; ++k) local[r.first + k] = f.star_to_local(ctrl[r.first + k]);
        break;
      case RingKind::arc:
        f = arc_frame(ctrl[r.from], ctrl[r.to], frames[r.up_ring].z, r.flip_up);
        for (uint32_t k = 0; k < r.count; ++k) local[r.first + k] = f.to_local(ctrl[r.first + k]);
        break;
      case RingKind::driven: {
        const auto& s = d.rings[r.s_ring];
        f = frames[r.s_ring];
        for (uint32_t k = 0; k < r.count; ++k) {
          const glm::vec3 sp = ctrl[s.first + k], g = ctrl[d.goals[r.goal_first + k]];
          const glm::vec3 res = ctrl[r.first + k] - (sp + r.alpha * (g - sp));
          local[r.first + k] = {glm::dot(res, f.x), glm::dot(res, f.y), glm::dot(res, f.z)};
        }
        break;
      }
    }
    frames[ri] = f;
  }
}

}  // namespace

const char* skin_method_name(SkinMethod m) { return m == SkinMethod::full ? "full" : "realtime"; }

Result<SkinMethod> parse_skin_method(std::string_view name) {
  if (name == "full") return SkinMethod::full;
  if (name == "realtime") return SkinMethod::realtime;
  return fail(Errc::invalid_argument, "skin method must be full or realtime, not '" + std::string(name) + "'");
}

RealtimeBody::RealtimeBody(std::unique_ptr<Data> data) : data_(std::move(data)) {}
RealtimeBody::~RealtimeBody() = default;

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::create(const BodyModel& model, const RealtimeOptions& options) {
  auto skeleton = Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  return create(model, *skeleton, options);
}

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::create(const BodyModel& model, const Skeleton& skeleton,
                                                                 const RealtimeOptions& options) {
  if (options.lod < 0 || options.lod >= kSkinLodCount)
    return fail(Errc::out_of_range, "skin LOD must be in 0.." + std::to_string(kSkinLodCount - 1));
  SkinOptions so;
  so.subdivision = 0;
  so.rigid_parts = options.rigid_parts;
  so.normals = true;
  auto skin = BodySkin::create(with_skin_lod(model, options.lod), skeleton, so);
  if (!skin) return tl::unexpected(skin.error());
  const Pose base = options.initial_pose ? *options.initial_pose : skeleton.zero_pose();
  if (base.dof_rad.size() != static_cast<size_t>(skeleton.dof_count()))
    return fail(Errc::invalid_argument, "initial pose has " + std::to_string(base.dof_rad.size()) +
                                            " DOF values, the skeleton " + std::to_string(skeleton.dof_count()));
  skin->evaluate(base);
  const BodySkin::Impl& m = *skin->impl_;

  auto d = std::make_unique<Data>();
  d->skeleton = skeleton;
  d->lod = options.lod;
  // A skeleton fitted to a performer may not fill the body's primitives everywhere: rays that
  // miss are placed as the full method places them, and counted.
  d->missed_rays = m.stats.missed_rays;
  d->chains = m.chains;
  for (const Ring& r : m.rings) {
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
    op.goal_first = static_cast<uint32_t>(d->goals.size());
    d->goals.insert(d->goals.end(), r.goal.begin(), r.goal.end());
    op.from = r.from;
    op.to = r.to;
    op.up_ring = r.up_ring;
    op.flip_up = r.flip_up;
    d->rings.push_back(op);
  }
  for (const Surface& s : m.surfaces) {
    int prev = -1;
    for (int id : s.rows) {
      if (id < 0 || m.rings[id].kind != RingKind::star) continue;
      d->rings[id].prev_star = prev;
      prev = id;
    }
  }
  d->local.resize(m.ctrl.size());
  measure_local(m.chains, m.rings, m.ctrl, *d, d->local);
  for (const Surface& s : m.surfaces)
    if (s.cap) {
      const auto& last = s.out_rows.back();
      d->caps.push_back({s.cap_vertex, last.front(), static_cast<uint32_t>(last.size())});
    }
  for (const RigidMesh& rm : m.rigid) {
    d->rigid.push_back({rm.joint, rm.first_vertex, static_cast<uint32_t>(d->rigid_local.size()),
                        static_cast<uint32_t>(rm.local.size())});
    d->rigid_local.insert(d->rigid_local.end(), rm.local.begin(), rm.local.end());
  }
  d->rest_mesh = m.mesh;
  auto weights = contour_skin_weights(*skin);
  if (!weights) return tl::unexpected(weights.error());
  d->weights = std::move(*weights);
  d->texture = ::mimic::avatar::texture_layout(*skin);
  for (const Surface& s : m.surfaces) {
    // The planar contours: star rings (a limb's loop and its boundary-driven rings blend the
    // torso into the limb and lie in no plane).
    ContourRows rows{s.name, {}};
    for (size_t r = 0; r < s.rows.size(); ++r)
      if (s.rows[r] >= 0 && m.rings[s.rows[r]].kind == RingKind::star) rows.rows.push_back(s.out_rows[r]);
    d->contour_rows.push_back(std::move(rows));
  }

  // Muscles: the contours with the primitives of every DOF that deforms one at θ0, θmin and
  // θmax; what moves in the rings' frames is what the muscles do there.
  std::vector<int> muscle_dof_of_dof(skeleton.dof_count(), -1);
  for (const Primitive& p : model.primitives) {
    if (!p.deformation) continue;
    const int dof = skeleton.find_dof(p.deformation->dof);
    if (dof < 0 || muscle_dof_of_dof[dof] >= 0) continue;
    const Dof& sd = skeleton.dof(dof);
    muscle_dof_of_dof[dof] = static_cast<int>(d->muscle_dofs.size());
    d->muscle_dofs.push_back({dof, sd.rest_rad, sd.min_rad, sd.max_rad, p.deformation->falloff});
  }
  std::vector<glm::vec3> at0(m.ctrl.size()), at_min(m.ctrl.size()), at_max(m.ctrl.size());
  // The posture stays the initial one (the rings' configuration moves the points with the
  // joints at run time); only the primitives take their shape at θ, so a term is the muscle's
  // own change of shape, which superposes over DOFs and postures.
  auto measure_at = [&](int dof, float theta, std::vector<glm::vec3>& out) {
    Pose p = base;
    p.dof_rad[dof] = theta;
    skin->stage_fk(base);
    skin->stage_deform(p);
    skin->stage_contours();
    measure_local(m.chains, m.rings, m.ctrl, *d, out);
  };
  constexpr float kMinMove_m = 1e-4f;  // smaller moves are not worth a term
  // Muscles shape the planar contours; boundary-driven rings and bridges follow them through
  // their S, G and end points (their own rays jump between surfaces at a junction, which a
  // term would carry into every pose).
  std::vector<uint8_t> is_star_slot(m.ctrl.size(), 0);
  for (const Ring& r : m.rings)
    if (r.kind == RingKind::star)
      for (uint32_t k : r.slots) is_star_slot[k] = 1;
  for (size_t md = 0; md < d->muscle_dofs.size(); ++md) {
    const Data::MuscleDof& dof = d->muscle_dofs[md];
    measure_at(dof.dof, dof.theta0, at0);
    measure_at(dof.dof, dof.theta_min, at_min);
    measure_at(dof.dof, dof.theta_max, at_max);
    // Exact in the initial pose: the term is zero at the base value of the DOF.
    const glm::vec2 wb = muscle_weights(base.dof_rad[dof.dof], dof.theta0, dof.theta_min, dof.theta_max, dof.falloff);
    for (size_t k = 0; k < m.ctrl.size(); ++k) {
      Data::MuscleTerm t;
      t.slot = static_cast<uint32_t>(k);
      t.dof = static_cast<uint32_t>(md);
      t.to_min = at_min[k] - at0[k];
      t.to_max = at_max[k] - at0[k];
      t.offset = -(wb.x * t.to_min + wb.y * t.to_max);
      const float moved = std::max({std::abs(t.to_min.x), std::abs(t.to_min.y), std::abs(t.to_min.z),
                                    std::abs(t.to_max.x), std::abs(t.to_max.y), std::abs(t.to_max.z)});
      if (moved > kMinMove_m && is_star_slot[k]) d->terms.push_back(t);
    }
  }
  std::stable_sort(d->terms.begin(), d->terms.end(), [](const auto& a, const auto& b) { return a.slot < b.slot; });
  for (size_t i = 0; i < d->terms.size(); ++i)
    if (i == 0 || d->terms[i].slot != d->terms[i - 1].slot) ++d->muscle_points;
  return std::shared_ptr<const RealtimeBody>(new RealtimeBody(std::move(d)));
}

const Skeleton& RealtimeBody::skeleton() const { return data_->skeleton; }
const Mesh& RealtimeBody::rest_mesh() const { return data_->rest_mesh; }
std::span<const JointInfluences> RealtimeBody::weights() const { return data_->weights; }
int RealtimeBody::lod() const { return data_->lod; }
const TextureLayout& RealtimeBody::texture_layout() const { return data_->texture; }
std::span<const ContourRows> RealtimeBody::contour_rows() const { return data_->contour_rows; }
size_t RealtimeBody::muscle_points() const { return data_->muscle_points; }
size_t RealtimeBody::muscle_terms() const { return data_->terms.size(); }
int RealtimeBody::missed_rays() const { return data_->missed_rays; }

size_t RealtimeBody::shared_bytes() const {
  const Data& d = *data_;
  size_t b = sizeof(Data) + d.rings.capacity() * sizeof(Data::RingOp) + d.goals.capacity() * 4 +
             d.local.capacity() * sizeof(glm::vec3) + d.terms.capacity() * sizeof(Data::MuscleTerm) +
             d.rigid_local.capacity() * sizeof(glm::vec3) + d.weights.capacity() * sizeof(JointInfluences) +
             d.texture.source.capacity() * 4 + d.texture.uv.capacity() * sizeof(glm::vec2) + d.texture.indices.capacity() * 4;
  b += d.rest_mesh.positions.capacity() * sizeof(glm::vec3) + d.rest_mesh.normals.capacity() * sizeof(glm::vec3) +
       d.rest_mesh.indices.capacity() * 4;
  return b;
}

// ---------------------------------------------------------------------------------------------
// Per avatar

struct RealtimeSkin::State {
  std::vector<RigidTransform> world_from_joint;
  std::vector<Chain> chains;
  std::vector<Frame> frames;        // per ring, this frame
  std::vector<glm::vec2> muscle_w;  // per muscle DOF: (towards θmin, towards θmax)
  RealtimeTimings timings;
};

RealtimeSkin::RealtimeSkin(std::shared_ptr<const RealtimeBody> body) : body_(std::move(body)), state_(std::make_unique<State>()) {
  const RealtimeBody::Data& d = body_->data();
  state_->world_from_joint.resize(d.skeleton.joint_count());
  state_->chains = d.chains;
  state_->frames.resize(d.rings.size());
  state_->muscle_w.resize(d.muscle_dofs.size());
}
RealtimeSkin::RealtimeSkin(RealtimeSkin&&) noexcept = default;
RealtimeSkin& RealtimeSkin::operator=(RealtimeSkin&&) noexcept = default;
RealtimeSkin::~RealtimeSkin() = default;

const RealtimeTimings& RealtimeSkin::timings() const { return state_->timings; }

size_t RealtimeSkin::instance_bytes() const {
  const State& s = *state_;
  size_t b = sizeof(*this) + sizeof(State) + s.world_from_joint.capacity() * sizeof(RigidTransform) +
             s.frames.capacity() * sizeof(Frame) + s.muscle_w.capacity() * sizeof(glm::vec2) +
             s.chains.capacity() * sizeof(Chain);
  for (const Chain& c : s.chains)
    b += c.nodes.capacity() * sizeof(Chain::Node) + (c.point.capacity() + c.normal.capacity() + c.ref.capacity()) * sizeof(glm::vec3);
  return b;
}

void RealtimeSkin::evaluate(const Pose& pose, std::span<glm::vec3> pos, std::span<glm::vec3> normals, bool muscles) {
  const RealtimeBody::Data& d = body_->data();
  State& st = *state_;
  if (pos.size() < d.rest_mesh.positions.size() || pose.dof_rad.size() != static_cast<size_t>(d.skeleton.dof_count()))
    return;  // a caller's sizing error; documented sizes
  const auto t0 = Clock::now();
  forward_kinematics(d.skeleton, pose, st.world_from_joint);
  for (Chain& c : st.chains) c.update(st.world_from_joint);
  for (size_t i = 0; i < d.muscle_dofs.size(); ++i) {
    const auto& md = d.muscle_dofs[i];
    st.muscle_w[i] = muscles ? muscle_weights(pose.dof_rad[md.dof], md.theta0, md.theta_min, md.theta_max, md.falloff)
                             : glm::vec2(0.0f);
  }
  const auto t1 = Clock::now();

  const RealtimeBody::Data::MuscleTerm* term = d.terms.data();
  const RealtimeBody::Data::MuscleTerm* const terms_end = muscles ? term + d.terms.size() : term;
  const glm::vec2* mw = st.muscle_w.data();
  // The local coordinates of slot k with its muscle terms (terms are sorted by slot, and rings
  // are visited in slot order).
  auto local_of = [&](uint32_t k) {
    glm::vec3 l = d.local[k];
    while (term != terms_end && term->slot == k) {
      const glm::vec2 w = mw[term->dof];
      l += term->offset + w.x * term->to_min + w.y * term->to_max;
      ++term;
    }
    return l;
  };
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    const auto& r = d.rings[ri];
    Frame& f = st.frames[ri];
    switch (r.kind) {
      case RingKind::star: {
        f = star_frame(st.chains[r.chain], r.segment, r.u, r.chain != kTorsoChain);
        for (uint32_t k = r.first; k < r.first + r.count; ++k) pos[k] = f.star_to_world(local_of(k));
        if (r.prev_star >= 0) {
          // Where a bend tilts this ring's plane through the previous one's (the inner side of
          // the joint), its points stop on the line the two planes share: the contours meet in
          // a crease there and never cross.
          const Frame& prev = st.frames[r.prev_star];
          const float origin_height = glm::dot(f.origin - prev.origin, prev.z);
          if (origin_height > 0.0f)
            for (uint32_t k = r.first; k < r.first + r.count; ++k) {
              const glm::vec3 v = pos[k] - f.origin;
              const float rise = glm::dot(v, prev.z);
              if (origin_height + rise < 0.0f) pos[k] = f.origin + (-origin_height / rise) * v;
            }
          // And the previous ring's points stop on that line from their side.
          const auto& pr = d.rings[r.prev_star];
          const float back = glm::dot(prev.origin - f.origin, f.z);
          if (back < 0.0f)
            for (uint32_t k = pr.first; k < pr.first + pr.count; ++k) {
              const glm::vec3 v = pos[k] - prev.origin;
              const float rise = glm::dot(v, f.z);
              if (back + rise > 0.0f) pos[k] = prev.origin + (-back / rise) * v;
            }
        }
        break;
      }
      case RingKind::arc: {
        f = arc_frame(pos[r.from], pos[r.to], st.frames[r.up_ring].z, r.flip_up);
        for (uint32_t k = r.first; k < r.first + r.count; ++k) pos[k] = f.to_world(local_of(k));
        break;
      }
      case RingKind::driven: {
        f = st.frames[r.s_ring];
        const uint32_t s_first = d.rings[r.s_ring].first;
        const uint32_t* goal = d.goals.data() + r.goal_first;
        for (uint32_t j = 0; j < r.count; ++j) {
          const glm::vec3 s = pos[s_first + j], g = pos[goal[j]];
          const glm::vec3 l = local_of(r.first + j);
          pos[r.first + j] = s + r.alpha * (g - s) + l.x * f.x + l.y * f.y + l.z * f.z;
        }
        break;
      }
    }
  }
  for (const auto& c : d.caps) {
    glm::vec3 sum(0.0f);
    for (uint32_t k = c.first; k < c.first + c.count; ++k) sum += pos[k];
    pos[c.vertex] = sum / static_cast<float>(c.count);
  }
  for (const auto& rg : d.rigid) {
    const RigidTransform& w = st.world_from_joint[rg.joint];
    const glm::mat3 r = glm::mat3_cast(w.rotation);
    for (uint32_t i = 0; i < rg.count; ++i) pos[rg.first_vertex + i] = r * d.rigid_local[rg.first_local + i] + w.translation;
  }
  const auto t2 = Clock::now();
  if (normals.size() >= pos.size()) {
    std::fill(normals.begin(), normals.end(), glm::vec3(0.0f));
    const auto& idx = d.rest_mesh.indices;
    for (size_t t = 0; t + 2 < idx.size(); t += 3) {
      const glm::vec3 a = pos[idx[t]], b = pos[idx[t + 1]], c = pos[idx[t + 2]];
      const glm::vec3 n = glm::cross(b - a, c - a);
      normals[idx[t]] += n;
      normals[idx[t + 1]] += n;
      normals[idx[t + 2]] += n;
    }
    for (size_t v = 0; v < d.rest_mesh.positions.size(); ++v) normals[v] = safe_normalize(normals[v], {0, 1, 0});
  }
  const auto t3 = Clock::now();
  st.timings.joints_us = std::chrono::duration<double, std::micro>(t1 - t0).count();
  st.timings.points_us = std::chrono::duration<double, std::micro>(t2 - t1).count();
  st.timings.normals_us = std::chrono::duration<double, std::micro>(t3 - t2).count();
}

}  // namespace mimic::avatar
