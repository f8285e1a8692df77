// The shoulders' bands swept as tubes in the realtime skin (band_sweep.h).
#include "band_sweep.h"

#include <algorithm>
#include <cmath>

#include "loop_follow.h"
#include "sweep_geometry.h"

namespace mimic::avatar::realtime_detail {

namespace {

using Data = RealtimeBody::Data;
using skin_detail::SweepColumns;
using skin_detail::SweepEnds;
using skin_detail::SweepPlane;

// The band's ends gathered from `pos` into the scratch (G through the loop's slots).
SweepEnds gather_ends(const Data& d, const Data::Sweep& b, std::span<const glm::vec3> pos, SweepScratch& sc) {
  const Data::RingOp& first = d.rings[static_cast<size_t>(b.first_ring)];
  const uint32_t* goal = d.goals.data() + first.goal_first;
  const uint32_t s_first = d.rings[static_cast<size_t>(first.s_ring)].first;
  for (uint32_t j = 0; j < b.columns; ++j) sc.g[j] = pos[goal[j]], sc.s[j] = pos[s_first + j];
  return {sc.g.data(), sc.s.data(), b.columns, b.sign_g, b.sign_s};
}

SweepColumns columns_of(SweepScratch& sc) {
  return {sc.ug_x.data(), sc.ug_y.data(), sc.r_g.data(), sc.h_g.data(), sc.r_s.data(), sc.h_s.data(), sc.turn.data()};
}

// The band's rings' t (0 at the loop, 1 at S), in ring order.
int ring_ts(const Data& d, const Data::Sweep& b, float* t) {
  const int rings = std::min(b.rings, skin_detail::kSweepMaxRings);
  for (int q = 0; q < rings; ++q) t[q] = 1.0f - d.rings[static_cast<size_t>(b.first_ring + q)].alpha;
  return rings;
}

}  // namespace

void SweepScratch::resize(size_t columns, size_t n_points) {
  for (std::vector<float>* v : {&ug_x, &ug_y, &r_g, &h_g, &r_s, &h_s, &turn, &shrink}) v->assign(columns, 0.0f);
  g.assign(columns, glm::vec3(0.0f));
  s.assign(columns, glm::vec3(0.0f));
  points.assign(n_points, glm::vec3(0.0f));
}

size_t SweepScratch::heap_bytes() const {
  return (ug_x.capacity() + ug_y.capacity() + r_g.capacity() + h_g.capacity() + r_s.capacity() + h_s.capacity() +
          turn.capacity() + shrink.capacity()) *
             sizeof(float) +
         (g.capacity() + s.capacity() + points.capacity()) * sizeof(glm::vec3);
}

float limb_twist_rad(const Data::Sweep& b, std::span<const rig::RigidTransform> world_from_joint) {
  const glm::quat local = glm::conjugate(world_from_joint[static_cast<size_t>(b.parent)].rotation) *
                          world_from_joint[static_cast<size_t>(b.joint)].rotation;
  return skin_detail::limb_twist_rad(local, b.rest_local_inv, b.rest_axis);
}

void sweep_band(const Data& d, const Data::Sweep& b, float twist_rad, std::span<const glm::vec3> pos, SweepScratch& sc,
                bool vectorised) {
  SweepPlane planes[skin_detail::kSweepMaxRings];
  float t[skin_detail::kSweepMaxRings];
  const int rings = ring_ts(d, b, t);
  const SweepEnds ends = gather_ends(d, b, pos, sc);
  const SweepColumns col = columns_of(sc);
  skin_detail::sweep_geometry(ends, t, rings, d.sweep_rest_cos.data() + b.column_first,
                              d.sweep_rest_sin.data() + b.column_first, twist_rad, vectorised, planes, col);
  const float* inv_len2 = d.column_inv_len2.data() + d.rings[static_cast<size_t>(b.first_ring)].first;
  for (uint32_t j = 0; j < b.columns; ++j) {
    const glm::vec3 gs = sc.g[j] - sc.s[j];
    sc.shrink[j] = std::min(1.0f, glm::dot(gs, gs) * inv_len2[j]);
  }
  for (int q = 0; q < rings; ++q) {
    const size_t at = b.offset_first + static_cast<size_t>(q) * b.columns;
    skin_detail::sweep_ring_points(planes[q], col, b.columns, d.sweep_rest_turn.data() + b.column_first,
                                   sc.shrink.data(), d.sweep_off_r.data() + at, d.sweep_off_a.data() + at,
                                   d.sweep_off_h.data() + at, vectorised,
                                   sc.points.data() + static_cast<size_t>(q) * b.columns);
  }
}

void measure_sweeps(std::span<const glm::vec3> rest, std::span<const rig::RigidTransform> world_from_joint, Data& d) {
  SweepScratch sc;
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    Data::RingOp& r = d.rings[ri];
    // The shoulders' bands: those that twist with their limb (loop_follow.h). LOD 3's four
    // points a ring keep the straight blend, which folds less there (0.4 against 1.2 folds a
    // frame, every 20th frame of the clips).
    if (r.kind != RingKind::driven || r.count < skin_detail::kSweepMinColumns || !r.twists || r.sweep >= 0 ||
        r.follow < 0)
      continue;
    const skin_detail::LoopFollow& lf = d.follows[static_cast<size_t>(r.follow)];
    if (lf.parent < 0) continue;
    Data::Sweep b;
    b.first_ring = static_cast<int>(ri);
    b.columns = r.count;
    b.joint = lf.joint, b.parent = lf.parent;
    b.rest_axis = lf.axis;
    b.rest_local_inv = glm::conjugate(glm::conjugate(world_from_joint[static_cast<size_t>(lf.parent)].rotation) *
                                      world_from_joint[static_cast<size_t>(lf.joint)].rotation);
    while (ri + static_cast<size_t>(b.rings) < d.rings.size()) {
      const Data::RingOp& o = d.rings[ri + static_cast<size_t>(b.rings)];
      if (o.kind != RingKind::driven || o.s_ring != r.s_ring || o.count != r.count) break;
      ++b.rings;
    }
    if (b.rings > skin_detail::kSweepMaxRings) continue;
    sc.resize(b.columns, static_cast<size_t>(b.columns) * static_cast<size_t>(b.rings));
    SweepEnds ends = gather_ends(d, b, rest, sc);
    skin_detail::sweep_signs(ends);
    b.sign_g = ends.sign_g, b.sign_s = ends.sign_s;
    SweepPlane planes[skin_detail::kSweepMaxRings];
    float t[skin_detail::kSweepMaxRings];
    const int rings = ring_ts(d, b, t);
    const SweepColumns col = columns_of(sc);
    // Each column's whole turn in the initial pose, then the geometry again as a frame sees it.
    skin_detail::sweep_geometry(ends, t, rings, nullptr, nullptr, 0.0f, false, planes, col);
    b.column_first = static_cast<uint32_t>(d.sweep_rest_turn.size());
    for (uint32_t j = 0; j < b.columns; ++j) {
      float c, s;
      skin_detail::approx_cos_sin(sc.turn[j], c, s);
      d.sweep_rest_turn.push_back(sc.turn[j]), d.sweep_rest_cos.push_back(c), d.sweep_rest_sin.push_back(s);
    }
    skin_detail::sweep_geometry(ends, t, rings, d.sweep_rest_cos.data() + b.column_first,
                                d.sweep_rest_sin.data() + b.column_first, 0.0f, false, planes, col);
    // The polar offsets that give the initial pose's points back.
    b.offset_first = static_cast<uint32_t>(d.sweep_off_r.size());
    for (int q = 0; q < rings; ++q) {
      Data::RingOp& o = d.rings[ri + static_cast<size_t>(q)];
      o.sweep = static_cast<int>(d.sweeps.size());
      for (uint32_t j = 0; j < b.columns; ++j) {
        const glm::vec3 off =
            skin_detail::sweep_offset(planes[q], col, j, d.sweep_rest_turn[b.column_first + j], rest[o.first + j]);
        d.sweep_off_r.push_back(off.x), d.sweep_off_a.push_back(off.y), d.sweep_off_h.push_back(off.z);
      }
    }
    d.sweeps.push_back(b);
  }
}

}  // namespace mimic::avatar::realtime_detail
