// The full method's contours: every frame, each ring is ray-cast on the implicit surface
// (star rings from their plane's origin, boundary-driven rings from the link, bridges as half
// stars from their chord).
#include "skin_impl.h"

namespace mimic::avatar {

// ---------------------------------------------------------------------------------------------
// Contours

int BodySkin::Impl::gather(GroupMask mask) {
  int n = 0;
  for (int i = 0; i < field.size() && n < kMaxCandidates; ++i)
    if (field.groups(i) & mask) candidates[n++] = static_cast<uint16_t>(i);
  return n;
}

void BodySkin::Impl::cast_into(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir,
                               std::span<const uint16_t> cand, const glm::vec3& fallback) {
  store(slot, origin, dir, field.cast_outermost(origin, dir, cand), fallback);
}

void BodySkin::Impl::store(uint32_t slot, const glm::vec3& origin, const glm::vec3& dir, RayHit hit,
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

void BodySkin::Impl::size_ring_buffers() {
  size_t widest = star_hits.size();
  for (const Ring& r : rings) widest = std::max(widest, r.slots.size());
  star_hits.resize(widest);
  ray_origins.resize(widest);
  ray_dirs.resize(widest);
  ray_fallbacks.resize(widest);
}

void BodySkin::Impl::compute_ring(const Ring& r) {
  switch (r.kind) {
    case RingKind::star: {
      const Plane p = ring_plane(chains[r.chain], r.segment, r.u);
      const int n = field.candidates_near_plane(p.origin, p.normal, r.mask, candidates);
      const std::span<const uint16_t> cand(candidates.data(), n);
      const Directions& dir = direction_tables[r.angles];
      const std::span<RayHit> hits(star_hits.data(), r.slots.size());
      field.cast_star(p.origin, p.front, p.left, dir.cos, dir.sin, cand, hits);
      for (size_t j = 0; j < r.slots.size(); ++j) {
        const glm::vec3 d = dir.cos[j] * p.front + dir.sin[j] * p.left;
        store(r.slots[j], p.origin, d, hits[j], p.origin + kMissRadius_m * d);
      }
      break;
    }
    case RingKind::driven: {
      const Ring& s = rings[r.s_ring];
      const Chain& c = chains[s.chain];
      const glm::vec3 a = c.point[0];
      const glm::vec3 axis = safe_normalize(c.point[1] - c.point[0], c.normal[0]);
      const int n = gather(r.mask);
      const std::span<const uint16_t> cand(candidates.data(), n);
      // Origins are P's projection on the link, kept between just before the joint and the
      // S ring: in extreme postures (an arm swung across the chest) the bare projection can
      // land far down the limb, from where the ray would miss the junction.
      const float s_along = glm::dot(ctrl_origin[s.slots[0]] - a, axis);
      const size_t m = r.slots.size();
      for (size_t j = 0; j < m; ++j) {
        const glm::vec3 sj = ctrl[s.slots[j]];
        const glm::vec3 pj = sj + r.alpha * (ctrl[r.goal[j]] - sj);
        const glm::vec3 o = a + std::clamp(glm::dot(pj - a, axis), -0.05f, std::max(s_along, -0.05f)) * axis;
        const glm::vec3 so = a + glm::dot(sj - a, axis) * axis;
        ray_origins[j] = o;
        ray_dirs[j] = safe_normalize(pj - o, safe_normalize(sj - so, c.normal[0]));
        ray_fallbacks[j] = pj;
      }
      // Every ray of the ring at once, eight in lock-step.
      const std::span<RayHit> hits(star_hits.data(), m);
      field.cast_rays(std::span(ray_origins.data(), m), std::span(ray_dirs.data(), m), cand, hits);
      for (size_t j = 0; j < m; ++j) store(r.slots[j], ray_origins[j], ray_dirs[j], hits[j], ray_fallbacks[j]);
      break;
    }
    case RingKind::arc: {
      const glm::vec3 from = ctrl[r.from], to = ctrl[r.to];
      const glm::vec3 o = 0.5f * (from + to);
      const glm::vec3 front = safe_normalize(from - o, {0, 0, 1});
      // "Up" is the normal of the ring the bridge leaves (the chest or crotch ring).
      const Ring& base = rings[r.up_ring];
      const Plane base_plane = ring_plane(chains[base.chain], base.segment, base.u);
      glm::vec3 up = r.flip_up ? -base_plane.normal : base_plane.normal;
      up = safe_normalize(up - glm::dot(up, front) * front, {0, 1, 0});
      const int n = gather(r.mask);
      const std::span<const uint16_t> cand(candidates.data(), n);
      // A half star from the chord's middle: one contour's worth of shared work.
      const int segs = static_cast<int>(r.slots.size()) + 1;
      const size_t m = r.slots.size();
      const Directions& dir = direction_tables[r.angles];
      const std::span<RayHit> hits(star_hits.data(), m);
      field.cast_star(o, front, up, dir.cos, dir.sin, cand, hits);
      for (int k = 1; k < segs; ++k) {
        const glm::vec3 d = dir.cos[static_cast<size_t>(k - 1)] * front + dir.sin[static_cast<size_t>(k - 1)] * up;
        const glm::vec3 chord = glm::mix(from, to, static_cast<float>(k) / static_cast<float>(segs));
        store(r.slots[k - 1], o, d, hits[static_cast<size_t>(k - 1)], chord);
      }
      break;
    }
  }
  ++stats.contours;
}

}  // namespace mimic::avatar
