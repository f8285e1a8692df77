// The realtime skin (realtime_skin.h), built once: contours ray-cast in the initial pose and
// measured in each ring's own frame, the columns of the rest surface along each limb, the muscle
// blocks and the joint bands' scales. realtime_deform.cpp moves them every frame.
#include <cstdio>

#include "mimic/avatar/joint_zone.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/avatar/texture_layout.h"
#include "realtime_data.h"

namespace mimic::avatar {

using namespace realtime_detail;

namespace {

using Data = RealtimeBody::Data;

// What the build reads of the full method's layout (BodySkin::Impl is the skin's own).
struct LayoutView {
  const std::vector<Surface>& surfaces;
  const std::vector<Ring>& rings;
  const std::vector<Chain>& chains;  // at the initial pose
  const std::vector<glm::vec3>& ctrl;
};

// Each slot's coordinates in its ring's frame, for the skin's current contours (the inverse of
// what realtime_detail::deform does with the columns at rest).
void measure_local(const std::vector<Chain>& chains, const std::vector<Ring>& rings, const std::vector<glm::vec3>& ctrl,
                   const Data& d, std::vector<glm::vec3>& local) {
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

// The limbs' star rings, surface by surface, in order along the limb.
std::vector<std::vector<int>> limb_star_rings(const LayoutView& m) {
  std::vector<std::vector<int>> out;
  for (const Surface& s : m.surfaces) {
    std::vector<int> stars;
    for (int id : s.rows)
      if (id >= 0 && m.rings[id].kind == RingKind::star && m.rings[id].chain != kTorsoChain) stars.push_back(id);
    if (!stars.empty()) out.push_back(std::move(stars));
  }
  return out;
}

// The columns (Data::lo_x …): in the initial pose, each limb point's neighbours on the previous
// and next star ring of the same link, in the point's own ring frame.
void measure_columns(const LayoutView& m, Data& d) {
  const size_t n = m.ctrl.size();
  d.lo_x.assign(n, 0.0f), d.lo_y.assign(n, 0.0f), d.hi_x.assign(n, 0.0f), d.hi_y.assign(n, 0.0f);
  d.dh_lo.assign(n, -1e3f), d.dh_hi.assign(n, 1e3f);
  for (const std::vector<int>& stars : limb_star_rings(m))
    for (size_t i = 0; i < stars.size(); ++i) {
      Data::RingOp& r = d.rings[stars[i]];
      const Frame f = star_frame(m.chains[r.chain], r.segment, r.u, true);
      r.rest_rise = f.rise();
      r.rest_a = f.along_per_normal;
      auto coords = [&](const glm::vec3& p) {  // (across x, across y, along the link)
        const glm::vec3 v = p - f.origin;
        return glm::vec3(glm::dot(v, f.px), glm::dot(v, f.py), glm::dot(v, f.axis));
      };
      for (const int step : {-1, 1}) {
        const int j = static_cast<int>(i) + step;
        if (j < 0 || j >= static_cast<int>(stars.size())) continue;
        const Data::RingOp& o = d.rings[stars[j]];
        // The joint ring cuts the first link; beyond it the next link's rings follow another
        // axis, so the first link's column runs straight on (the two links meet as a mitre).
        if (o.segment != r.segment || o.count != r.count) continue;
        for (uint32_t k = 0; k < r.count; ++k) {
          const glm::vec3 a = coords(m.ctrl[r.first + k]), b = coords(m.ctrl[o.first + k]);
          const float dh = b.z - a.z;
          if (step < 0 ? dh > -1e-4f : dh < 1e-4f) continue;
          const glm::vec2 slope = (glm::vec2(b) - glm::vec2(a)) / dh;
          const uint32_t s = r.first + k;
          if (step < 0) d.lo_x[s] = slope.x, d.lo_y[s] = slope.y, d.dh_lo[s] = dh;
          else d.hi_x[s] = slope.x, d.hi_y[s] = slope.y, d.dh_hi[s] = dh;
        }
      }
    }
}

// The bending DOF of a joint: of its DOFs, the one that bends the chain most over its range.
int bending_dof(const rig::Skeleton& skeleton, const Chain& chain_template, int joint, const rig::Pose& base) {
  Chain c = chain_template;
  std::vector<rig::RigidTransform> w(skeleton.joint_count());
  int best = -1;
  float best_bend = 0.05f;
  for (int i = 0; i < skeleton.dof_count(); ++i) {
    const rig::Dof& dof = skeleton.dof(i);
    if (dof.joint != joint) continue;
    for (float theta : {dof.min_rad, dof.max_rad}) {
      rig::Pose p = base;
      p.dof_rad[i] = theta;
      rig::forward_kinematics(skeleton, p, w);
      c.update(w);
      const float bend = chain_bend(c);
      if (bend > best_bend) best_bend = bend, best = i;
    }
  }
  return best;
}

// Joint bands at the elbows and knees: the star rings within 1.5 zone half-lengths of the joint
// (35% of the shorter link, as `mimic inspect` measures the zone) take the band's scale, fully
// within half a half-length and fading out beyond. Then, for bends sampled over the joint's
// range, the scale that gives the joint zone (joint_zone.h) the volume it has in the initial
// pose, found by the secant method on the realtime skin itself.
Status calibrate_bands(const LayoutView& m, const rig::Pose& base, Data& d) {
  const rig::Skeleton& sk = d.skeleton;
  for (const std::vector<int>& stars : limb_star_rings(m)) {
    const int chain = d.rings[stars.front()].chain;
    const Chain& c = m.chains[chain];
    if (c.nodes.size() != 3) continue;  // the neck has no bending middle joint of its own
    const int joint = c.nodes[1].joint, parent = sk.parent(joint);
    if (parent < 0) continue;
    const float len0 = glm::length(c.point[1] - c.point[0]), len1 = glm::length(c.point[2] - c.point[1]);
    const float half = 0.35f * std::min(len0, len1);
    const int band = static_cast<int>(d.bands.size());
    for (int id : stars) {
      Data::RingOp& r = d.rings[id];
      const float dist = r.segment == 0 ? (1.0f - r.u) * len0 : r.u * len1;
      const float t = std::clamp((dist - 0.5f * half) / half, 0.0f, 1.0f);
      if (t >= 1.0f) continue;
      r.band = band;
      r.band_weight = 0.5f * (1.0f + std::cos(kPi * t));
    }
    Data::Band b;
    b.chain = chain;
    d.bands.push_back(b);

    const int dof = bending_dof(sk, c, joint, base);
    if (dof < 0) continue;  // scale 1 throughout
    const rig::Dof& dd = sk.dof(dof);
    const float theta_b = base.dof_rad[dof];
    const float theta_end = std::abs(dd.max_rad - theta_b) >= std::abs(dd.min_rad - theta_b) ? dd.max_rad : dd.min_rad;
    // The zone's two pieces, named as the surface's parts.
    std::vector<std::string> parts;
    for (const Surface& s : m.surfaces)
      if (std::find(s.rows.begin(), s.rows.end(), stars.front()) != s.rows.end())
        for (const auto& [name, row] : s.parts) parts.push_back(name);
    const std::vector<uint32_t> tris = part_triangles(d.rest_mesh, parts);
    if (tris.empty()) continue;

    State st(d);
    st.band_scale_forced.assign(d.bands.size(), 1.0f);
    std::vector<glm::vec3> pos(d.rest_mesh.positions.size());
    constexpr int kSamples = 12;
    for (int muscles = 0; muscles < 2; ++muscles) {
      std::vector<float> bends, scales;
      double v_rest = 0;
      float k = 1.0f;
      for (int i = 0; i < kSamples; ++i) {
        rig::Pose p = base;
        p.dof_rad[dof] = theta_b + (theta_end - theta_b) * static_cast<float>(i) / (kSamples - 1);
        auto volume_at = [&](float scale) {
          st.band_scale_forced[band] = scale;
          deform(d, st, p, pos, muscles == 1);
          const glm::vec3 centre = st.world_from_joint[joint].translation;
          const JointZone zone{centre, safe_normalize(st.world_from_joint[parent].translation - centre, {0, 1, 0}),
                               safe_normalize(st.world_from_joint[joint].apply(sk.tip_m(joint)) - centre, {0, -1, 0}),
                               half};
          return joint_zone_volume(pos, d.rest_mesh.indices, tris, zone);
        };
        if (i == 0) {
          v_rest = volume_at(1.0f);
          k = 1.0f;
        } else {
          // V grows about as k²: start from the last sample's k, then secant steps.
          float k0 = k, k1 = k;
          double v0 = volume_at(k0);
          k1 = k0 * static_cast<float>(std::sqrt(v_rest / std::max(v0, 1e-12)));
          for (int it = 0; it < 8; ++it) {
            const double v1 = volume_at(k1);
            if (std::abs(v1 / v_rest - 1.0) < 1e-5 || std::abs(v1 - v0) < 1e-15) break;
            const float k2 = k1 + static_cast<float>((v_rest - v1) * (k1 - k0) / (v1 - v0));
            k0 = k1, v0 = v1, k1 = std::clamp(k2, 0.5f, 2.0f);
          }
          k = k1;
        }
        bends.push_back(chain_bend(st.chains[chain]));
        scales.push_back(k);
      }
      // Sorted by bend, and exactly 1 from the initial pose's bend down.
      std::vector<size_t> order(bends.size());
      for (size_t i = 0; i < order.size(); ++i) order[i] = i;
      std::sort(order.begin(), order.end(), [&](size_t a, size_t b2) { return bends[a] < bends[b2]; });
      Data::Band& out = d.bands[band];
      out.bend_rad.clear();
      out.scale[muscles].clear();
      for (size_t i : order) {
        out.bend_rad.push_back(bends[i]);
        out.scale[muscles].push_back(i == 0 ? 1.0f : scales[i]);
      }
    }
  }
  return {};
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
  auto skeleton = rig::Skeleton::build(model.skeleton);
  if (!skeleton) return tl::unexpected(skeleton.error());
  return create(model, *skeleton, options);
}

Result<std::shared_ptr<const RealtimeBody>> RealtimeBody::create(const BodyModel& model, const rig::Skeleton& skeleton,
                                                                 const RealtimeOptions& options) {
  if (options.lod < 0 || options.lod >= kSkinLodCount)
    return fail(Errc::out_of_range, "skin LOD must be in 0.." + std::to_string(kSkinLodCount - 1));
  SkinOptions so;
  so.subdivision = 0;
  so.rigid_parts = options.rigid_parts;
  so.normals = true;
  auto skin = BodySkin::create(with_skin_lod(model, options.lod), skeleton, so);
  if (!skin) return tl::unexpected(skin.error());
  const rig::Pose base = options.initial_pose ? *options.initial_pose : skeleton.zero_pose();
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
  std::vector<glm::vec3> local(m.ctrl.size());
  measure_local(m.chains, m.rings, m.ctrl, *d, local);
  d->lx.resize(local.size()), d->ly.resize(local.size()), d->lz.resize(local.size());
  for (size_t k = 0; k < local.size(); ++k) d->lx[k] = local[k].x, d->ly[k] = local[k].y, d->lz[k] = local[k].z;
  measure_columns(LayoutView{m.surfaces, m.rings, m.chains, m.ctrl}, *d);
  for (size_t ri = 0; ri < d->rings.size(); ++ri) {
    const Data::RingOp& r = d->rings[ri];
    if (r.kind != RingKind::star) continue;
    const bool along = r.chain != kTorsoChain;
    auto& runs = d->frame_runs;
    if (runs.empty() || runs.back().chain != r.chain || runs.back().segment != r.segment) {
      Data::FrameRun run;
      run.chain = r.chain, run.segment = r.segment, run.along_link = along;
      run.first = static_cast<uint32_t>(d->run_rings.size());
      runs.push_back(run);
    }
    d->run_rings.push_back(static_cast<uint32_t>(ri));
    d->run_u.push_back(r.u);
    ++runs.back().count;
  }
  d->run_u.resize(d->run_u.size() + 8, 0.0f);
  for (Data::RingOp& r : d->rings) {
    if (r.kind != RingKind::star || r.count < 3) continue;
    // The ring's rest centroid across the link (the band scale's centre).
    double a2 = 0, cx = 0, cy = 0;
    for (uint32_t k = 0; k < r.count; ++k) {
      const uint32_t i = r.first + k, j = r.first + (k + 1) % r.count;
      const double cr = double(d->lx[i]) * d->ly[j] - double(d->lx[j]) * d->ly[i];
      a2 += cr, cx += (d->lx[i] + d->lx[j]) * cr, cy += (d->ly[i] + d->ly[j]) * cr;
    }
    if (std::abs(a2) > 1e-12) r.centre = glm::vec2(static_cast<float>(cx / (3 * a2)), static_cast<float>(cy / (3 * a2)));
  }
  for (const Surface& s : m.surfaces)
    if (s.cap) {
      const auto& last = s.out_rows.back();
      d->caps.push_back({s.cap_vertex, last.front(), static_cast<uint32_t>(last.size())});
    }
  for (const RigidMesh& rm : m.rigid) {
    d->rigid.push_back({rm.joint, rm.first_vertex, static_cast<uint32_t>(d->rigid_local.size()),
                        static_cast<uint32_t>(rm.local.size()), rm.toe_joint, static_cast<uint32_t>(d->toe_vertex.size()),
                        static_cast<uint32_t>(rm.toe_vertex.size())});
    d->rigid_local.insert(d->rigid_local.end(), rm.local.begin(), rm.local.end());
    for (uint32_t v : rm.toe_vertex) d->toe_vertex.push_back(rm.first_vertex + v);
    d->toe_weight.insert(d->toe_weight.end(), rm.toe_weight.begin(), rm.toe_weight.end());
    d->toe_local.insert(d->toe_local.end(), rm.toe_local.begin(), rm.toe_local.end());
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
    const rig::Dof& sd = skeleton.dof(dof);
    muscle_dof_of_dof[dof] = static_cast<int>(d->muscle_dofs.size());
    d->muscle_dofs.push_back({dof, sd.rest_rad, sd.min_rad, sd.max_rad, p.deformation->falloff});
  }
  const size_t n = m.ctrl.size();
  std::vector<glm::vec3> at0(n), at_min(n), at_max(n);
  // The posture stays the initial one (the rings' configuration moves the points with the
  // joints at run time); only the primitives take their shape at θ, so a term is the muscle's
  // own change of shape, which superposes over DOFs and postures.
  auto measure_at = [&](int dof, float theta, std::vector<glm::vec3>& out) {
    rig::Pose p = base;
    p.dof_rad[dof] = theta;
    skin->stage_fk(base);
    skin->stage_deform(p);
    skin->stage_contours();
    measure_local(m.chains, m.rings, m.ctrl, *d, out);
  };
  constexpr float kMinMove_m = 1e-4f;  // smaller moves are not worth a term
  // Muscles shape the planar contours; boundary-driven rings and bridges follow them through
  // their S, G and end points (their own rays jump between surfaces at a junction, which a
  // term would carry into every pose). Per star ring and DOF, one dense block over the ring's
  // points (zero where a point does not move), applied eight lanes at a time.
  struct Term {
    glm::vec3 offset, to_min, to_max;
  };
  std::vector<std::vector<Term>> ring_terms(d->rings.size() * d->muscle_dofs.size());
  std::vector<uint8_t> moved_slot(n, 0);
  for (size_t md = 0; md < d->muscle_dofs.size(); ++md) {
    const Data::MuscleDof& dof = d->muscle_dofs[md];
    measure_at(dof.dof, dof.theta0, at0);
    measure_at(dof.dof, dof.theta_min, at_min);
    measure_at(dof.dof, dof.theta_max, at_max);
    // Exact in the initial pose: the term is zero at the base value of the DOF.
    const glm::vec2 wb = muscle_weights(base.dof_rad[dof.dof], dof.theta0, dof.theta_min, dof.theta_max, dof.falloff);
    for (size_t ri = 0; ri < d->rings.size(); ++ri) {
      const Data::RingOp& r = d->rings[ri];
      if (r.kind != RingKind::star) continue;
      std::vector<Term> terms(r.count, Term{glm::vec3(0.0f), glm::vec3(0.0f), glm::vec3(0.0f)});
      bool any = false;
      for (uint32_t j = 0; j < r.count; ++j) {
        const uint32_t k = r.first + j;
        Term t;
        t.to_min = at_min[k] - at0[k];
        t.to_max = at_max[k] - at0[k];
        t.offset = -(wb.x * t.to_min + wb.y * t.to_max);
        const float moved = std::max({std::abs(t.to_min.x), std::abs(t.to_min.y), std::abs(t.to_min.z),
                                      std::abs(t.to_max.x), std::abs(t.to_max.y), std::abs(t.to_max.z)});
        if (moved <= kMinMove_m) continue;
        terms[j] = t;
        any = true;
        moved_slot[k] = 1;
        ++d->muscle_terms;
      }
      if (any) ring_terms[ri * d->muscle_dofs.size() + md] = std::move(terms);
    }
  }
  for (size_t ri = 0; ri < d->rings.size(); ++ri) {
    Data::RingOp& r = d->rings[ri];
    r.muscle_first = static_cast<uint32_t>(d->muscle_blocks.size());
    for (size_t md = 0; md < d->muscle_dofs.size(); ++md) {
      const std::vector<Term>& terms = ring_terms[ri * d->muscle_dofs.size() + md];
      if (terms.empty()) continue;
      d->muscle_blocks.push_back({static_cast<uint32_t>(md), static_cast<uint32_t>(d->muscle_data.size())});
      const size_t at = d->muscle_data.size();
      d->muscle_data.resize(at + 9 * size_t(r.count));
      float* out = d->muscle_data.data() + at;
      for (uint32_t j = 0; j < r.count; ++j) {
        const Term& t = terms[j];
        const float v[9] = {t.offset.x, t.offset.y, t.offset.z, t.to_min.x, t.to_min.y, t.to_min.z, t.to_max.x, t.to_max.y, t.to_max.z};
        for (int c = 0; c < 9; ++c) out[size_t(c) * r.count + j] = v[c];
      }
    }
    r.muscle_count = static_cast<uint32_t>(d->muscle_blocks.size()) - r.muscle_first;
  }
  for (uint8_t s : moved_slot) d->muscle_points += s;
  // The eight-wide kernels read a ring's last chunk whole: eight entries of padding at the end.
  for (std::vector<float>* v : {&d->lx, &d->ly, &d->lz, &d->lo_x, &d->lo_y, &d->hi_x, &d->hi_y, &d->muscle_data})
    v->resize(v->size() + 8, 0.0f);
  d->dh_lo.resize(d->dh_lo.size() + 8, -1e3f);
  d->dh_hi.resize(d->dh_hi.size() + 8, 1e3f);
  // The contour stages above left the skin at the base pose's chains; the bands need them.
  skin->stage_fk(base);
  if (auto st = calibrate_bands(LayoutView{m.surfaces, m.rings, m.chains, m.ctrl}, base, *d); !st) return tl::unexpected(st.error());
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

RealtimeBody::FrameWork RealtimeBody::work_per_frame(bool muscles) const {
  // Per point, as realtime_points.cpp does it (eight lanes or one, the same operations).
  constexpr double kStarRead = 9 * 4, kStarFlops = 55;    // coordinates, columns; scale … plane
  constexpr double kMuscleRead = 9 * 4, kMuscleFlops = 15;  // one block: offset, to_min, to_max
  constexpr double kDrivenRead = 3 * 12 + 4, kDrivenFlops = 27;  // S, G (gathered), offset, index
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
      case RingKind::driven: w.bytes_read += n * kDrivenRead, w.flops += n * kDrivenFlops; break;
      case RingKind::arc: w.bytes_read += n * kArcRead, w.flops += n * kArcFlops; break;
    }
    w.bytes_written += n * 12;
  }
  for (const Data::Cap& c : d.caps) w.bytes_read += c.count * 12.0, w.flops += c.count * 3.0, w.bytes_written += 12;
  for (const Data::Rigid& rg : d.rigid) w.bytes_read += rg.count * kRigidRead, w.flops += rg.count * kRigidFlops, w.bytes_written += rg.count * 12.0;
  return w;
}

size_t RealtimeBody::shared_bytes() const {
  const Data& d = *data_;
  size_t b = sizeof(Data) + d.rings.capacity() * sizeof(Data::RingOp) + d.goals.capacity() * 4 +
             (d.lx.capacity() + d.ly.capacity() + d.lz.capacity()) * 4 +
             (d.lo_x.capacity() + d.lo_y.capacity() + d.hi_x.capacity() + d.hi_y.capacity() + d.dh_lo.capacity() +
              d.dh_hi.capacity()) * 4 +
             d.muscle_blocks.capacity() * sizeof(Data::MuscleBlock) + d.muscle_data.capacity() * 4 +
             d.frame_runs.capacity() * sizeof(Data::FrameRun) + (d.run_rings.capacity() + d.run_u.capacity()) * 4 +
             d.rigid_local.capacity() * sizeof(glm::vec3) + d.weights.capacity() * sizeof(JointInfluences) +
             d.toe_vertex.capacity() * 4 + d.toe_weight.capacity() * 4 + d.toe_local.capacity() * sizeof(glm::vec3) +
             d.texture.source.capacity() * 4 + d.texture.uv.capacity() * sizeof(glm::vec2) + d.texture.indices.capacity() * 4;
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

size_t RealtimeSkin::instance_bytes() const { return sizeof(*this) + sizeof(State) + state_->heap_bytes(); }

void RealtimeSkin::use_scalar_reference(bool scalar) { state_->vectorised = !scalar; }

void RealtimeSkin::evaluate(const rig::Pose& pose, std::span<glm::vec3> pos, std::span<glm::vec3> normals, bool muscles) {
  const RealtimeBody::Data& d = body_->data();
  if (pos.size() < d.rest_mesh.positions.size() || pose.dof_rad.size() != static_cast<size_t>(d.skeleton.dof_count()))
    return;  // a caller's sizing error; documented sizes
  deform(d, *state_, pose, pos, muscles);
  const auto t2 = std::chrono::steady_clock::now();
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
  state_->timings.normals_us =
      normals.size() >= pos.size() ? std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t2).count() : 0.0;
}

}  // namespace mimic::avatar
