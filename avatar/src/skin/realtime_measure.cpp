// The realtime body's measurements of its contours (realtime_data.h): each point in its ring's
// frame, the columns of the rest surface along each limb, the joint bands' scales and the muscle
// terms, from the contours the implicit skin ray-casts in the initial pose.
#include <cmath>
#include <string_view>

#include "mimic/avatar/joint_zone.h"
#include "realtime_data.h"

namespace mimic::avatar::realtime_detail {

namespace {
using Data = RealtimeBody::Data;
}  // namespace

void measure_local(const RestContours& m, const Data& d, std::vector<glm::vec3>& local) {
  const std::vector<Chain>& chains = m.chains;
  const std::vector<Ring>& rings = m.layout.rings;
  const std::span<const glm::vec3> ctrl = m.ctrl;
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
        f = junction_frame(d, r, ctrl, frames[r.s_ring], 1.0f);
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

void measure_driven_columns(const RestContours& m, Data& d) {
  d.column_inv_len2.assign(m.ctrl.size(), 0.0f);
  for (const Data::RingOp& r : d.rings) {
    if (r.kind != RingKind::driven) continue;
    const uint32_t s_first = d.rings[r.s_ring].first;
    for (uint32_t k = 0; k < r.count; ++k) {
      const glm::vec3 column = m.ctrl[d.goals[r.goal_first + k]] - m.ctrl[s_first + k];
      const float len2 = glm::dot(column, column);
      // A column of no length at rest: its offset never shrinks.
      d.column_inv_len2[r.first + k] = len2 > 1e-12f ? 1.0f / len2 : 0.0f;
    }
  }
}

void measure_loop_follows(const RestContours& m, const rig::Pose& base, Data& d) {
  std::vector<rig::RigidTransform> w(static_cast<size_t>(d.skeleton.joint_count()));
  rig::forward_kinematics(d.skeleton, base, w);
  d.band_in_s.assign(d.rings.size(), glm::mat3(1.0f));
  d.band_twist_rest.assign(d.rings.size(), 0.0f);
  for (Data::RingOp& r : d.rings) {
    if (r.kind != RingKind::driven || r.count == 0) continue;
    const Data::RingOp& s = d.rings[static_cast<size_t>(r.s_ring)];
    {
      const Ring& src = m.layout.rings[static_cast<size_t>(r.s_ring)];
      const Frame sf = star_frame(m.chains[static_cast<size_t>(s.chain)], src.segment, src.u, s.chain != kTorsoChain);
      const Frame bf = junction_frame(d, r, m.ctrl, sf, 1.0f);
      d.band_in_s[static_cast<size_t>(r.s_ring)] =
          glm::transpose(glm::mat3(sf.x, sf.y, sf.z)) * glm::mat3(bf.x, bf.y, bf.z);
      d.band_twist_rest[static_cast<size_t>(r.s_ring)] = band_twist_rad(sf, bf);
    }
    const int joint = m.chains[static_cast<size_t>(s.chain)].nodes.front().joint;
    const skin_detail::LoopFollowRule* rule = skin_detail::loop_follow_rule(d.skeleton.joint_name(joint));
    if (rule == nullptr || d.skeleton.parent(joint) < 0) continue;  // the neck keeps its loop
    r.twists = rule->twist_power > 0.0f;
    r.twist_share = std::pow(1.0f - r.alpha, rule->twist_power);
    // One follow per loop, moved before the first of its driven rings.
    int seen = -1;
    for (size_t i = 0; i < d.follows.size(); ++i)
      if (d.follows[i].joint == joint) seen = static_cast<int>(i);
    r.follow = seen;
    if (seen >= 0) continue;
    const Ring& driven = m.layout.rings[static_cast<size_t>(&r - d.rings.data())];
    d.follows.push_back(skin_detail::measure_loop_follow(m.layout, m.chains, m.ctrl, w, driven, *rule));
    r.follow = static_cast<int>(d.follows.size()) - 1;
    r.moves_loop = true;
  }
}

namespace {

// The limbs' star rings, surface by surface, in order along the limb.
std::vector<std::vector<int>> limb_star_rings(const RestContours& m) {
  std::vector<std::vector<int>> out;
  for (const Surface& s : m.layout.surfaces) {
    std::vector<int> stars;
    for (int id : s.rows)
      if (id >= 0 && m.layout.rings[id].kind == RingKind::star && m.layout.rings[id].chain != kTorsoChain)
        stars.push_back(id);
    if (!stars.empty()) out.push_back(std::move(stars));
  }
  return out;
}

// The columns (Data::lo_x …): in the initial pose, each limb point's neighbours on the previous
// and next star ring of the same link, in the point's own ring frame.
}  // namespace

void measure_columns(const RestContours& m, Data& d) {
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
          if (step < 0)
            d.lo_x[s] = slope.x, d.lo_y[s] = slope.y, d.dh_lo[s] = dh;
          else
            d.hi_x[s] = slope.x, d.hi_y[s] = slope.y, d.dh_hi[s] = dh;
        }
      }
    }
}

namespace {

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
}  // namespace

// Each limb star ring rounds the tip of the nearer of its link's joints: the elbow or knee (both
// links' rings) or the wrist or ankle (the forearm's and shin's); the neck's, its middle joint or
// the head's.
void measure_joint_tips(const RestContours& m, Data& d) {
  d.tip_radius2.assign(m.ctrl.size() + 8, 0.0f);  // padded for the eight-wide kernel
  for (const std::vector<int>& stars : limb_star_rings(m))
    for (int id : stars) {
      Data::RingOp& r = d.rings[id];
      const Chain& c = m.chains[r.chain];
      if (c.nodes.size() != 3) continue;  // three joints in a row: arms, legs, the neck
      r.tip_node = r.segment == 1 && r.u > 0.5f ? 2 : 1;
      const glm::vec3 centre = c.point[r.tip_node];
      const glm::vec3 along = tip_direction(c, r.segment, r.tip_node);
      for (uint32_t k = r.first; k < r.first + r.count; ++k) {
        const glm::vec3 v = m.ctrl[k] - centre;
        const float past = glm::dot(v, along);
        d.tip_radius2[k] = past > 0.0f ? glm::dot(v, v) : glm::dot(v, v) - past * past;
      }
    }
}

namespace {

// The scale in [0.5, 2] at which `volume_at` (growing with the scale, about as its square, with
// kinks where the rounded tip's points start or stop sliding) gives `v_rest`, from the last
// sample's `start`: secant steps while they stay inside the bracket found so far, else the
// bracket's midpoint, until within 1e-5 of the volume. Returns the scale and the volume it gives.
struct ScaleFound {
  float scale;
  double volume;
};
template <typename VolumeAt>
ScaleFound scale_keeping_volume(VolumeAt&& volume_at, double v_rest, float start) {
  float lo = 0.5f, hi = 2.0f;
  ScaleFound best{start, volume_at(start)}, last = best;
  (best.volume < v_rest ? lo : hi) = start;
  float k = std::clamp(start * static_cast<float>(std::sqrt(v_rest / std::max(best.volume, 1e-12))), lo, hi);
  for (int it = 0; it < 24 && std::abs(best.volume / v_rest - 1.0) >= 1e-5; ++it) {
    const ScaleFound now{k, volume_at(k)};
    if (std::abs(now.volume - v_rest) < std::abs(best.volume - v_rest)) best = now;
    (now.volume < v_rest ? lo : hi) = k;
    if (hi - lo < 1e-6f) break;
    const double dv = now.volume - last.volume;
    float next = std::abs(dv) > 1e-15 ? k + static_cast<float>((v_rest - now.volume) * (k - last.scale) / dv) : lo;
    if (!(next > lo && next < hi)) next = 0.5f * (lo + hi);
    last = now, k = next;
  }
  return best;
}

}  // namespace

Status calibrate_bands(const RestContours& m, const rig::Pose& base, Data& d) {
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
    for (const Surface& s : m.layout.surfaces)
      if (std::find(s.rows.begin(), s.rows.end(), stars.front()) != s.rows.end())
        for (const auto& [name, row] : s.parts) parts.push_back(name);
    const std::vector<uint32_t> tris = part_triangles(d.rest_mesh, parts);
    if (tris.empty()) continue;

    State st(d);
    st.band_scale_forced.assign(d.bands.size(), 1.0f);
    std::vector<glm::vec3> pos(d.rest_mesh.positions.size());
    constexpr int kSamples = 12;
    // With the joint's tip rounded (round_joint_tip) the scales keep the zone's volume where the
    // rings are close enough; where no scale up to 2 can (a coarse level of detail, whose few
    // rings the rounding cuts deep), the joint keeps its mitre and the scales are found again.
    constexpr double kMostVolumeChange = 0.02;
    for (int attempt = 0; attempt < 2; ++attempt) {
      double worst_change = 0;
      for (int muscles = 0; muscles < 2; ++muscles) {
        std::vector<float> bends, scales;
        double v_rest = 0;
        float k = 1.0f;
        for (int i = 0; i < kSamples; ++i) {
          rig::Pose p = base;
          p.dof_rad[dof] = theta_b + (theta_end - theta_b) * static_cast<float>(i) / (kSamples - 1);
          auto volume_at = [&](float scale) {
            st.band_scale_forced[band] = scale;
            deform(d, st, p, pos, muscles == 1, false);
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
            const ScaleFound found = scale_keeping_volume(volume_at, v_rest, k);
            k = found.scale;
            worst_change = std::max(worst_change, std::abs(found.volume / v_rest - 1.0));
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
      bool rounded = false;
      for (int id : stars) rounded = rounded || d.rings[id].tip_node == 1;
      if (worst_change <= kMostVolumeChange || !rounded) break;
      for (int id : stars)
        if (d.rings[id].tip_node == 1) d.rings[id].tip_node = -1;
    }
  }
  return {};
}

namespace {

// Every DOF that deforms a primitive, once, with the range the primitive's shape follows.
void find_muscle_dofs(const BodyModel& model, const rig::Skeleton& skeleton, Data& d) {
  std::vector<int> muscle_dof_of_dof(skeleton.dof_count(), -1);
  for (const Primitive& p : model.primitives) {
    if (!p.deformation) continue;
    const int dof = skeleton.find_dof(p.deformation->dof);
    if (dof < 0 || muscle_dof_of_dof[dof] >= 0) continue;
    const rig::Dof& sd = skeleton.dof(dof);
    muscle_dof_of_dof[dof] = static_cast<int>(d.muscle_dofs.size());
    d.muscle_dofs.push_back({dof, sd.rest_rad, sd.min_rad, sd.max_rad, p.deformation->falloff});
  }
}

struct Term {
  glm::vec3 offset, to_min, to_max;
};

// Per star ring and muscle DOF, one dense block over the ring's points (zero where a point does
// not move), laid out as nine arrays of the ring's count (Data::MuscleBlock).
void pack_muscle_blocks(const std::vector<std::vector<Term>>& ring_terms, Data& d) {
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    Data::RingOp& r = d.rings[ri];
    r.muscle_first = static_cast<uint32_t>(d.muscle_blocks.size());
    for (size_t md = 0; md < d.muscle_dofs.size(); ++md) {
      const std::vector<Term>& terms = ring_terms[ri * d.muscle_dofs.size() + md];
      if (terms.empty()) continue;
      d.muscle_blocks.push_back({static_cast<uint32_t>(md), static_cast<uint32_t>(d.muscle_data.size())});
      const size_t at = d.muscle_data.size();
      d.muscle_data.resize(at + 9 * size_t(r.count));
      float* out = d.muscle_data.data() + at;
      for (uint32_t j = 0; j < r.count; ++j) {
        const Term& t = terms[j];
        const float v[9] = {t.offset.x, t.offset.y, t.offset.z, t.to_min.x, t.to_min.y,
                            t.to_min.z, t.to_max.x, t.to_max.y, t.to_max.z};
        for (int c = 0; c < 9; ++c) out[size_t(c) * r.count + j] = v[c];
      }
    }
    r.muscle_count = static_cast<uint32_t>(d.muscle_blocks.size()) - r.muscle_first;
  }
}

}  // namespace

// Muscles: the contours with the primitives of every DOF that deforms one at θ0, θmin and
// θmax; what moves in the rings' frames is what the muscles do there.
void measure_muscles(const BodyModel& model, ImplicitSkin& skin, const RestContours& m, const rig::Pose& base,
                     Data& d) {
  find_muscle_dofs(model, d.skeleton, d);
  const size_t n = m.ctrl.size();
  std::vector<glm::vec3> at0(n), at_min(n), at_max(n);
  // The posture stays the initial one (the rings' configuration moves the points with the
  // joints at run time); only the primitives take their shape at θ, so a term is the muscle's
  // own change of shape, which superposes over DOFs and postures.
  auto measure_at = [&](int dof, float theta, std::vector<glm::vec3>& out) {
    rig::Pose p = base;
    p.dof_rad[dof] = theta;
    skin.stage_fk(base);
    skin.stage_deform(p);
    skin.stage_contours();
    measure_local(m, d, out);
  };
  constexpr float kMinMove_m = 1e-4f;  // smaller moves are not worth a term
  // Muscles shape the planar contours; boundary-driven rings and bridges follow them through
  // their S, G and end points (their own rays jump between surfaces at a junction, which a
  // term would carry into every pose).
  std::vector<std::vector<Term>> ring_terms(d.rings.size() * d.muscle_dofs.size());
  std::vector<uint8_t> moved_slot(n, 0);
  for (size_t md = 0; md < d.muscle_dofs.size(); ++md) {
    const Data::MuscleDof& dof = d.muscle_dofs[md];
    measure_at(dof.dof, dof.theta0, at0);
    measure_at(dof.dof, dof.theta_min, at_min);
    measure_at(dof.dof, dof.theta_max, at_max);
    // Exact in the initial pose: the term is zero at the base value of the DOF.
    const glm::vec2 wb = muscle_weights(base.dof_rad[dof.dof], dof.theta0, dof.theta_min, dof.theta_max, dof.falloff);
    for (size_t ri = 0; ri < d.rings.size(); ++ri) {
      const Data::RingOp& r = d.rings[ri];
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
        ++d.muscle_terms;
      }
      if (any) ring_terms[ri * d.muscle_dofs.size() + md] = std::move(terms);
    }
  }
  pack_muscle_blocks(ring_terms, d);
  for (uint8_t s : moved_slot) d.muscle_points += s;
}

}  // namespace mimic::avatar::realtime_detail
