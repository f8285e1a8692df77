// The full method's contours: every frame, each ring is ray-cast on the implicit surface
// (star rings from their plane's origin, boundary-driven rings from the link, bridges as half
// stars from their chord).
#include <glm/gtc/quaternion.hpp>

#include "skin_impl.h"

namespace mimic::avatar {

namespace {
// A boundary-driven ray searches the surface around P no further than this fraction of |P − O|
// and half the spacing of consecutive rings, so the rings keep their order from S to G.
constexpr float kDrivenReach = 0.3f;
}  // namespace

// ---------------------------------------------------------------------------------------------
// Contours

int RingCaster::gather(const BodyField& field, GroupMask mask) {
  int n = 0;
  for (int i = 0; i < field.size() && n < kMaxCandidates; ++i)
    if (field.groups(i) & mask) candidates[n++] = static_cast<uint16_t>(i);
  return n;
}

void RingCaster::store(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir, RayHit hit,
                       const glm::vec3& fallback) {
  ++stats.rays;
  ctrl_origin[slot] = origin;
  if (hit.hit()) {
    ctrl[slot] = origin + hit.t * dir;
    ctrl_hit[slot] = 1;
  } else {
    ctrl[slot] = fallback;
    ctrl_hit[slot] = 0;
    ++stats.missed_rays;
  }
}

// A bridge's radii arc_r[0 … m+1] along directions at increasing angles from 0 (its first end)
// to π (its other end) in its plane: a point further out than both its neighbours is brought
// back to the further of them (a ray grazing a bulge of the next part, such as the pectoral's
// edge beside the front armpit), and points inside the convex hull of the others (a hollow such
// as the one between pectoral and deltoid) are pushed out onto it along their ray, as skin
// spans a hollow. The loops the arc closes then go round their limb without folding back.
void RingCaster::span_arc(size_t m, const Directions& dir) {
  const size_t np = m + 2;
  auto cos_of = [&](size_t i) { return i == 0 ? 1.0f : i == np - 1 ? -1.0f : dir.cos[i - 1]; };
  auto sin_of = [&](size_t i) { return i == 0 || i == np - 1 ? 0.0f : dir.sin[i - 1]; };
  for (size_t i = 1; i + 1 < np; ++i) arc_spike[i] = std::max(arc_r[i - 1], arc_r[i + 1]);
  for (size_t i = 1; i + 1 < np; ++i) arc_r[i] = std::min(arc_r[i], arc_spike[i]);
  auto point = [&](size_t i) { return glm::vec2(cos_of(i), sin_of(i)) * arc_r[i]; };
  auto cross = [](glm::vec2 a, glm::vec2 b) { return a.x * b.y - a.y * b.x; };
  // Upper hull, monotone in angle: a vertex that does not turn left lies in a hollow.
  size_t h = 0;
  for (size_t i = 0; i < np; ++i) {
    while (h >= 2 && cross(point(arc_hull[h - 1]) - point(arc_hull[h - 2]), point(i) - point(arc_hull[h - 1])) <= 0.0f)
      --h;
    arc_hull[h++] = static_cast<uint32_t>(i);
  }
  for (size_t e = 0; e + 1 < h; ++e) {
    const glm::vec2 a = point(arc_hull[e]), edge = point(arc_hull[e + 1]) - a;
    for (size_t i = arc_hull[e] + 1; i < arc_hull[e + 1]; ++i) {
      const float denom = cross(glm::vec2(cos_of(i), sin_of(i)), edge);
      if (denom > 1e-12f) arc_r[i] = std::max(arc_r[i], cross(a, edge) / denom);
    }
  }
}

void RingCaster::size_for(size_t control_points, size_t widest) {
  ctrl.resize(control_points);
  ctrl_origin.resize(control_points);
  ctrl_hit.resize(control_points);
  candidates.resize(kMaxCandidates);
  star_hits.resize(widest);
  ray_origins.resize(widest);
  ray_dirs.resize(widest);
  ray_fallbacks.resize(widest);
  ray_nears.resize(widest);
  arc_r.resize(widest + 2);
  arc_spike.resize(widest + 2);
  arc_hull.resize(widest + 2);
  rest_inv_len2.assign(control_points, 0.0f);
  driven_p.resize(control_points);
}

void RingCaster::remember_rest_columns(const ContourLayout::Data& layout, std::span<const Chain> chains) {
  for (const Ring& r : layout.rings) {
    if (r.kind != RingKind::driven) continue;
    const Ring& s = layout.rings[r.s_ring];
    for (size_t j = 0; j < r.slots.size(); ++j)
      rest_inv_len2[r.slots[j]] = 1.0f / std::max(glm::length2(ctrl[r.goal[j]] - ctrl[s.slots[j]]), 1e-12f);
  }
  band_twist_power.assign(layout.rings.size(), 0.0f);
  band_twist_rest_rad.assign(layout.rings.size(), 0.0f);
  chain_swing_rad.assign(chains.size(), 0.0f);
  for (const Ring& r : layout.rings) {
    if (r.kind != RingKind::driven || r.slots.empty()) continue;
    const Ring& s = layout.rings[r.s_ring];
    const skin_detail::LoopFollowRule* rule =
        skin_detail::loop_follow_rule(layout.skeleton.joint_name(chains[s.chain].nodes.front().joint));
    if (rule == nullptr || rule->twist_power <= 0.0f) continue;
    glm::vec3 origin, axis;
    band_twist_rest_rad[r.s_ring] = band_twist_rad(layout, chains, r, origin, axis);
    band_twist_power[r.s_ring] = rule->twist_power;
  }
}

// φ: the angle about the band's axis (the loop's centre to S's) from the loop's first point to
// S's front (its rays' angle 0); `origin` and `axis` receive the band's axis.
float RingCaster::band_twist_rad(const ContourLayout::Data& layout, std::span<const Chain> chains, const Ring& r,
                                 glm::vec3& origin, glm::vec3& axis) const {
  const Ring& s = layout.rings[r.s_ring];
  const size_t m = r.slots.size();
  glm::vec3 loop(0.0f), ring(0.0f);
  for (size_t j = 0; j < m; ++j) loop += ctrl[r.goal[j]], ring += ctrl[s.slots[j]];
  loop /= static_cast<float>(m), ring /= static_cast<float>(m);
  const Plane p = ring_plane(chains[s.chain], s.segment, s.u);
  origin = loop;
  axis = safe_normalize(ring - loop, p.normal);
  const glm::vec3 first = ctrl[r.goal[0]] - loop;
  const glm::vec3 x = safe_normalize(first - glm::dot(first, axis) * axis, p.front);
  const glm::vec3 y = glm::cross(axis, x);
  const glm::vec3 front = p.front - glm::dot(p.front, axis) * axis;
  return std::atan2(glm::dot(front, y), glm::dot(front, x));
}

void RingCaster::driven_targets(const ContourLayout::Data& layout, std::span<const Chain> chains, const Ring& r) {
  const Ring& s = layout.rings[r.s_ring];
  const size_t m = r.slots.size();
  float phi_rad = 0.0f;
  if (static_cast<size_t>(r.s_ring) < band_twist_power.size() && band_twist_power[r.s_ring] > 0.0f) {
    if (twist_s_ring != r.s_ring) {
      twist_phi_rad =
          twist_in_band(band_twist_rad(layout, chains, r, twist_origin, twist_axis) - band_twist_rest_rad[r.s_ring]) *
          band_follow_fade(chain_swing_rad[s.chain]);
      twist_s_ring = r.s_ring;
    }
    phi_rad = twist_phi_rad;
  }
  const glm::vec3 origin = twist_origin, axis = twist_axis;
  if (phi_rad == 0.0f) {
    for (size_t j = 0; j < m; ++j)
      driven_p[r.slots[j]] = ctrl[s.slots[j]] + r.alpha * (ctrl[r.goal[j]] - ctrl[s.slots[j]]);
    return;
  }
  const float share = std::pow(1.0f - r.alpha, band_twist_power[static_cast<size_t>(r.s_ring)]);
  const glm::mat3 turn = glm::mat3_cast(glm::angleAxis(share * phi_rad, axis));
  const glm::mat3 to_s = (1.0f - r.alpha) * turn * glm::mat3_cast(glm::angleAxis(-phi_rad, axis));
  const glm::mat3 to_g = r.alpha * turn;
  for (size_t j = 0; j < m; ++j)
    driven_p[r.slots[j]] = origin + to_s * (ctrl[s.slots[j]] - origin) + to_g * (ctrl[r.goal[j]] - origin);
}

void RingCaster::compute_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                              const Ring& r) {
  switch (r.kind) {
    case RingKind::star: star_ring(layout, field, chains, r); break;
    case RingKind::driven: driven_ring(layout, field, chains, r); break;
    case RingKind::arc: arc_ring(layout, field, chains, r); break;
  }
  ++stats.contours;
}

void RingCaster::star_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                           const Ring& r) {
  const Plane p = ring_plane(chains[r.chain], r.segment, r.u);
  const int n = field.candidates_near_plane(p.origin, p.normal, r.mask, candidates);
  const std::span<const uint16_t> cand(candidates.data(), n);
  const Directions& dir = layout.direction_tables[r.angles];
  const std::span<RayHit> hits(star_hits.data(), r.slots.size());
  field.cast_star(p.origin, p.front, p.left, dir.cos, dir.sin, cand, hits);
  for (size_t j = 0; j < r.slots.size(); ++j) {
    const glm::vec3 d = dir.cos[j] * p.front + dir.sin[j] * p.left;
    // Cut short by the ring's reach: inside its surface, no longer where the ray found it.
    const bool bounded = !r.reach_m.empty() && hits[j].hit() && hits[j].t > r.reach_m[j];
    if (bounded) hits[j].t = r.reach_m[j];
    store(r.slots[j], p.origin, d, hits[j], p.origin + kMissRadius_m * d);
    if (bounded) ctrl_hit[r.slots[j]] = 0;
  }
}

void RingCaster::driven_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                             const Ring& r) {
  const Ring& s = layout.rings[r.s_ring];
  const Chain& c = chains[s.chain];
  const glm::vec3 a = c.point[0];
  const glm::vec3 axis = safe_normalize(c.point[1] - c.point[0], c.normal[0]);
  const int n = gather(field, r.mask);
  const std::span<const uint16_t> cand(candidates.data(), n);
  // Origins are P's projection on the link, kept between just before the joint and the
  // S ring: in extreme postures (an arm swung across the chest) the bare projection can
  // land far down the limb, from where the ray would miss the junction.
  const float s_along = glm::dot(ctrl_origin[s.slots[0]] - a, axis);
  // How far the limb's root is bent from the zero posture: the first node's normal leans from
  // the link towards its rest direction (ImplicitSkin::Impl::tilt_limb_roots) by a lean a little
  // under half the bend; with c its cosine, 2c² − 1 is about the bend's cosine.
  const float cos_half = glm::dot(c.normal[0], axis);
  float straight = std::clamp(2.0f * cos_half * cos_half - 1.0f, 0.0f, 1.0f);
  if (straight > 0.999f) straight = 1.0f;
  const float straight4 = (straight * straight) * (straight * straight);
  const size_t m = r.slots.size();
  driven_targets(layout, chains, r);
  for (size_t j = 0; j < m; ++j) {
    const glm::vec3 sj = ctrl[s.slots[j]];
    const glm::vec3 pj = driven_p[r.slots[j]];
    const glm::vec3 o = a + std::clamp(glm::dot(pj - a, axis), -0.05f, std::max(s_along, -0.05f)) * axis;
    const glm::vec3 so = a + glm::dot(sj - a, axis) * axis;
    ray_origins[j] = o;
    ray_dirs[j] = safe_normalize(pj - o, safe_normalize(sj - so, c.normal[0]));
    // The surface is searched only around P, where the solid around P ends (inwards from P
    // outside the body, outwards from P inside it): the outermost crossing along the whole
    // ray is, at a junction, often another part of the body (the other thigh across the
    // crotch, the chest under a hanging arm, the shoulder's top beyond the neck's loop).
    const float tp = glm::length(pj - o);
    const float spacing = r.alpha_step * glm::length(ctrl[r.goal[j]] - sj);
    // The window closes as the root bends and as the column from S to G is squeezed (both to
    // the fourth power; 1 in the zero posture): a bent junction's surface near P is as often
    // the limb's other side or the torso's as the band's own, and points that found it on
    // either side of neighbours folded the band. Closed, the point is P, the blend of S and G.
    const float rest = rest_inv_len2[r.slots[j]];
    float squeeze = rest > 0.0f ? std::min(1.0f, glm::length2(ctrl[r.goal[j]] - sj) * rest) : 1.0f;
    if (squeeze > 0.999f) squeeze = 1.0f;
    const float squeeze4 = (squeeze * squeeze) * (squeeze * squeeze);
    const float reach = straight4 * squeeze4 * std::min(kDrivenReach * tp, 0.5f * spacing);
    ray_nears[j] = RayNear{tp, std::max(tp - reach, 0.0f), tp + reach};
    ray_fallbacks[j] = o + ray_nears[j].t_min * ray_dirs[j];
  }
  // Every ray of the ring at once, eight in lock-step.
  const std::span<RayHit> hits(star_hits.data(), m);
  field.cast_rays_nearest(std::span(ray_origins.data(), m), std::span(ray_dirs.data(), m),
                          std::span(ray_nears.data(), m), cand, hits);
  for (size_t j = 0; j < m; ++j) {
    // No crossing within the window: the point stays at the window's end nearer the surface
    // (its outer end where the solid goes on past it, else its inner end).
    const bool beyond = hits[j].hit() && hits[j].t >= ray_nears[j].t_max;
    if (beyond || !hits[j].hit()) {
      ++stats.rays;
      ++stats.windowed_rays;
      ctrl_origin[r.slots[j]] = ray_origins[j];
      ctrl[r.slots[j]] = beyond ? ray_origins[j] + ray_nears[j].t_max * ray_dirs[j] : ray_fallbacks[j];
      ctrl_hit[r.slots[j]] = 0;
    } else {
      store(r.slots[j], ray_origins[j], ray_dirs[j], hits[j], ray_fallbacks[j]);
    }
  }
}

void RingCaster::arc_ring(const ContourLayout::Data& layout, const BodyField& field, std::span<const Chain> chains,
                          const Ring& r) {
  const glm::vec3 from = ctrl[r.from], to = ctrl[r.to];
  const glm::vec3 o = 0.5f * (from + to);
  const glm::vec3 front = safe_normalize(from - o, {0, 0, 1});
  // "Up" is the normal of the ring the bridge leaves (the chest or crotch ring).
  const Ring& base = layout.rings[r.up_ring];
  const Plane base_plane = ring_plane(chains[base.chain], base.segment, base.u);
  glm::vec3 up = r.flip_up ? -base_plane.normal : base_plane.normal;
  up = safe_normalize(up - glm::dot(up, front) * front, {0, 1, 0});
  const int n = gather(field, r.mask);
  const std::span<const uint16_t> cand(candidates.data(), n);
  // A half star from the chord's middle: one contour's worth of shared work.
  const int segs = static_cast<int>(r.slots.size()) + 1;
  const size_t m = r.slots.size();
  const Directions& dir = layout.direction_tables[r.angles];
  const std::span<RayHit> hits(star_hits.data(), m);
  field.cast_star(o, front, up, dir.cos, dir.sin, cand, hits);
  for (int k = 1; k < segs; ++k) {
    const glm::vec3 d = dir.cos[static_cast<size_t>(k - 1)] * front + dir.sin[static_cast<size_t>(k - 1)] * up;
    const glm::vec3 chord = glm::mix(from, to, static_cast<float>(k) / static_cast<float>(segs));
    store(r.slots[k - 1], o, d, hits[static_cast<size_t>(k - 1)], chord);
  }
  // The arc as skin spans it, from its two ends on the ring it leaves: radii along the rays
  // (a miss counts as 0), one end at angle 0 and the other at π.
  const float half = glm::length(from - o);
  arc_r[0] = half;
  for (size_t k = 0; k < m; ++k) arc_r[k + 1] = hits[k].hit() ? hits[k].t : 0.0f;
  arc_r[m + 1] = half;
  span_arc(m, dir);
  for (size_t k = 0; k < m; ++k) {
    if (arc_r[k + 1] == (hits[k].hit() ? hits[k].t : 0.0f)) continue;
    const glm::vec3 d = dir.cos[k] * front + dir.sin[k] * up;
    ctrl[r.slots[k]] = o + arc_r[k + 1] * d;
    ctrl_hit[r.slots[k]] = 0;
  }
}

}  // namespace mimic::avatar
