// The realtime skin's frame (realtime_skin.h): joint transforms, chain nodes and one frame per
// ring, then every contour point moved by its ring's configuration. Never allocates.

#if defined(__SSE__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <glm/gtx/quaternion.hpp>

#include "mimic/core/clock.h"
#include "band_sweep.h"
#include "realtime_data.h"
#include "sweep_geometry.h"

namespace mimic::avatar::realtime_detail {

namespace {

using Data = RealtimeBody::Data;

// Most a ring's section is stretched along its tilt (1/0.3, a ring tilted 72.5° against its
// link): beyond, a sharply bent joint would push its outer side far out. The inner side is held
// by the crease.
constexpr float kMinLinkCos = 0.3f;

// The crease: where a bend tilts ring `r`'s plane through the previous star ring's (the inner
// side of the joint), the points of both stop on the line the two planes share, so adjacent
// contours meet and never cross. A point v from its ring's origin rises over the other plane by
// at most |v|·sin(angle between the planes) + |its height over its own plane|, so most pairs
// (nearly parallel planes, or far apart) are passed over without visiting their points.
void crease(const Data::RingOp& r, const Data::RingOp& pr, const Frame& f, const Frame& prev, const Reach& reach,
            const Reach& prev_reach, std::span<glm::vec3> pos) {
  const float cos_planes = glm::dot(f.z, prev.z);
  const float sin_planes = std::sqrt(std::max(0.0f, 1.0f - cos_planes * cos_planes));
  const float origin_height = glm::dot(f.origin - prev.origin, prev.z);
  if (origin_height > 0.0f && origin_height < reach.radius * sin_planes + reach.height * 1.0001f + 1e-6f)
    for (uint32_t k = r.first; k < r.first + r.count; ++k) {
      const glm::vec3 v = pos[k] - f.origin;
      const float rise = glm::dot(v, prev.z);
      if (origin_height + rise < 0.0f) pos[k] = f.origin + (-origin_height / rise) * v;
    }
  const float back = glm::dot(prev.origin - f.origin, f.z);
  if (back < 0.0f && -back < prev_reach.radius * sin_planes + prev_reach.height * 1.0001f + 1e-6f)
    for (uint32_t k = pr.first; k < pr.first + pr.count; ++k) {
      const glm::vec3 v = pos[k] - prev.origin;
      const float rise = glm::dot(v, f.z);
      if (back + rise > 0.0f) pos[k] = prev.origin + (-back / rise) * v;
    }
}

}  // namespace

// 1/|v| to float precision (the hardware estimate and one Newton step: a few cycles where a
// square root and a division take twenty); v must not be zero.
inline float inv_length(const glm::vec3& v) {
  const float l2 = glm::dot(v, v);
#if defined(__SSE__)
  const float y = _mm_cvtss_f32(_mm_rsqrt_ss(_mm_set_ss(l2)));
  return y * (1.5f - 0.5f * l2 * y * y);
#else
  return 1.0f / std::sqrt(l2);
#endif
}

inline glm::vec3 unit_or(const glm::vec3& v, const glm::vec3& fallback) {
  return glm::dot(v, v) > 1e-20f ? v * inv_length(v) : fallback;
}

Frame star_frame(const Chain& c, int segment, float u, bool along_link) {
  // The ring's plane as ring_plane (skin_impl.h) places it for the full method, with the
  // normalisations by reciprocal square root: the frames are this function's both when the
  // points are measured and when they are moved, so the initial pose stays exact.
  const int a = segment, b = std::min<int>(segment + 1, static_cast<int>(c.point.size()) - 1);
  Frame f;
  f.origin = c.point[a] + u * (c.point[b] - c.point[a]);
  const glm::vec3 normal = unit_or(c.normal[a] + u * (c.normal[b] - c.normal[a]), c.normal[a]);
  const glm::vec3 ref = c.ref[a] + u * (c.ref[b] - c.ref[a]);
  glm::vec3 front = ref - glm::dot(ref, normal) * normal;
  if (glm::dot(front, front) < 1e-10f)
    front = glm::cross(normal, std::abs(normal.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
  f.x = front * inv_length(front);
  f.z = normal;
  f.y = glm::cross(normal, f.x);
  f.axis = along_link ? unit_or(c.point[b] - c.point[a], normal) : normal;
  if (glm::dot(f.axis, normal) < 0.0f) f.axis = -f.axis;
  const float cos_tilt = glm::dot(f.axis, normal);
  if (cos_tilt < kMinLinkCos) {
    // Tilted past the bound: project along an axis turned towards the normal until it is at
    // the bound, so the points still land on the ring's plane.
    const glm::vec3 tilt = unit_or(f.axis - cos_tilt * normal, f.x);
    f.axis = kMinLinkCos * normal + std::sqrt(1.0f - kMinLinkCos * kMinLinkCos) * tilt;
  }
  f.along_per_normal = 1.0f / glm::dot(f.axis, normal);
  f.px = unit_or(f.x - glm::dot(f.x, f.axis) * f.axis, f.y);
  f.py = glm::cross(f.axis, f.px);
  return f;
}

namespace {

// Whether any point of a star ring (its frame `f`, this frame's reach) can be past its tip node:
// its reach across its plane times the sine of the plane's tilt from the link, and its height
// over the plane, against how far short of the joint its origin is (a straight limb's rings
// short of the joint never are).
bool may_pass_joint(const Frame& f, const Reach& reach, const TipRound& t) {
  const float short_m = -(t.origin_past + reach.height);
  const float cos_tilt = glm::dot(t.along, f.z);
  return !(short_m > 0.0f && reach.radius * reach.radius * (1.0f - cos_tilt * cos_tilt) <= short_m * short_m);
}

}  // namespace

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

float chain_bend(const Chain& c) {
  if (c.point.size() < 3) return 0.0f;
  const glm::vec3 in = safe_normalize(c.point[1] - c.point[0], {0, 1, 0});
  const glm::vec3 out = safe_normalize(c.point[2] - c.point[1], in);
  return std::acos(std::clamp(glm::dot(in, out), -1.0f, 1.0f));
}

State::State(const Data& d)
    : world_from_joint(d.skeleton.joint_count()),
      chains(d.chains),
      frames(d.rings.size()),
      muscle_w(d.muscle_dofs.size()),
      band_scale(d.bands.size(), 1.0f),
      follow_fade(d.follows.size(), 1.0f),
      tip_along(2 * d.chains.size()),
      reach(d.rings.size()) {
  contact.resize(d.contact);
  size_t columns = 0, points = 0;
  for (const Data::Sweep& b : d.sweeps) {
    columns = std::max<size_t>(columns, b.columns);
    points = std::max(points, static_cast<size_t>(b.columns) * static_cast<size_t>(b.rings));
  }
  sweep.resize(columns, points);
}

size_t State::heap_bytes() const {
  size_t b = world_from_joint.capacity() * sizeof(rig::RigidTransform) + frames.capacity() * sizeof(Frame) +
             muscle_w.capacity() * sizeof(glm::vec2) + chains.capacity() * sizeof(Chain) +
             (band_scale.capacity() + band_scale_forced.capacity() + follow_fade.capacity()) * sizeof(float) +
             tip_along.capacity() * sizeof(glm::vec3) + reach.capacity() * sizeof(Reach) + contact.heap_bytes() +
             sweep.heap_bytes();
  for (const Chain& c : chains)
    b += c.nodes.capacity() * sizeof(Chain::Node) +
         (c.point.capacity() + c.normal.capacity() + c.ref.capacity()) * sizeof(glm::vec3);
  return b;
}

Frame band_axis_frame(const Data& d, const Data::RingOp& r, std::span<const glm::vec3> pos,
                      const glm::vec3& fallback_z) {
  const Data::RingOp& s = d.rings[static_cast<size_t>(r.s_ring)];
  glm::vec3 loop(0.0f), ring(0.0f);
  for (uint32_t k = 0; k < r.count; ++k) loop += pos[d.goals[r.goal_first + k]], ring += pos[s.first + k];
  const float inv = 1.0f / static_cast<float>(std::max(r.count, 1u));
  loop *= inv, ring *= inv;
  Frame f;
  f.origin = loop;
  f.z = safe_normalize(ring - loop, fallback_z);
  const glm::vec3 first = pos[d.goals[r.goal_first]] - loop;
  f.x = safe_normalize(first - glm::dot(first, f.z) * f.z,
                       glm::abs(f.z.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
  f.x = safe_normalize(f.x - glm::dot(f.x, f.z) * f.z, {1, 0, 0});
  f.y = glm::cross(f.z, f.x);
  return f;
}

Frame junction_frame(const Data& d, const Data::RingOp& r, std::span<const glm::vec3> pos, const Frame& s_frame,
                     float band) {
  return junction_frame(d, r, band_axis_frame(d, r, pos, s_frame.z), s_frame, band);
}

Frame junction_frame(const Data& d, const Data::RingOp& r, Frame f, const Frame& s_frame, float band) {
  if (band >= 1.0f) return f;
  // Towards S's frame turned as the band's frame was from it in the initial pose (band 0: the
  // offsets turn with S alone, as they did before the band had its frame).
  const glm::mat3 with_s = glm::mat3(s_frame.x, s_frame.y, s_frame.z) * d.band_in_s[static_cast<size_t>(r.s_ring)];
  const glm::quat q = glm::slerp(glm::quat_cast(with_s), glm::quat_cast(glm::mat3(f.x, f.y, f.z)), band);
  const glm::mat3 m = glm::mat3_cast(q);
  f.x = m[0], f.y = m[1], f.z = m[2];
  return f;
}

float band_twist_rad(const Frame& s, const Frame& axis) {
  const glm::vec3 sx = s.x - glm::dot(s.x, axis.z) * axis.z;
  return std::atan2(glm::dot(sx, axis.y), glm::dot(sx, axis.x));
}

BandTwist band_twist(const Data::RingOp& r, const Frame& axis, const Frame& f, float phi_rad,
                     const glm::mat3& untwist) {
  const glm::mat3 turn = glm::mat3_cast(glm::angleAxis(r.twist_share * phi_rad, axis.z));
  const glm::mat3 back = turn * untwist;
  BandTwist t;
  t.to_s = (1.0f - r.alpha) * back;
  t.to_g = r.alpha * turn;
  t.offset = turn * glm::mat3(f.x, f.y, f.z);
  t.origin = axis.origin - t.to_s * axis.origin - t.to_g * axis.origin;
  return t;
}

namespace {

// What a limb's boundary-driven rings share, from its first ring to its last.
struct BandState {
  int s_ring = -1;
  Frame frame, axis;
  float phi_rad = 0.0f;
  glm::mat3 untwist{1.0f};
  float swept = 0.0f;  // the swept band's share (band_sweep.h) this frame
};

// A boundary-driven ring: P = S + α(G − S), plus the offset the full method's ray found from
// that point in the initial pose, turned with the band (junction_frame); a shoulder's band is
// swept instead (band_sweep.h), all its rings at its first, or blended with that as the arm's
// twist nears half a turn.
void driven_ring(const Data& d, State& st, size_t ri, std::span<glm::vec3> pos, BandState& b) {
  const Data::RingOp& r = d.rings[ri];
  if (r.s_ring != b.s_ring) {
    float fade = 1.0f;
    if (r.follow >= 0) {
      const auto i = static_cast<size_t>(r.follow);
      if (r.moves_loop) {
        const skin_detail::LoopFollow& lf = d.follows[i];
        const Frame& cap = st.frames[static_cast<size_t>(std::max(lf.cap_ring, 0))];
        const Frame& limb = st.frames[static_cast<size_t>(r.s_ring)];
        st.follow_fade[i] =
            skin_detail::follow_loop(lf, st.world_from_joint, cap.origin, cap.z, limb.origin, limb.z, pos);
      }
      fade = st.follow_fade[i];
    }
    b.s_ring = r.s_ring;
    b.swept = 0.0f;
    if (r.sweep >= 0) {
      const Data::Sweep& sweep = d.sweeps[static_cast<size_t>(r.sweep)];
      const float twist_rad = limb_twist_rad(sweep, st.world_from_joint);
      b.swept = skin_detail::sweep_share(twist_rad, fade);
      if (b.swept > 0.0f) sweep_band(d, sweep, twist_rad, pos, st.sweep, kHasAvx2Kernel && st.vectorised);
    }
    // The straight band's frame and twist, only where it is drawn (no ring's frame outlives
    // its band).
    if (b.swept < 1.0f) {
      const Frame& s_frame = st.frames[r.s_ring];
      b.axis = band_axis_frame(d, r, pos, s_frame.z);
      b.frame = junction_frame(d, r, b.axis, s_frame, fade);
      if (r.twists) {
        b.phi_rad =
            twist_in_band(band_twist_rad(s_frame, b.axis) - d.band_twist_rest[static_cast<size_t>(r.s_ring)]) * fade;
        b.untwist = glm::mat3_cast(glm::angleAxis(-b.phi_rad, b.axis.z));
      }
    }
  }
  if (b.swept < 1.0f) {
    st.frames[ri] = b.frame;
    if (r.twists)
      driven_points_twisted(d, r, band_twist(r, b.axis, b.frame, b.phi_rad, b.untwist), pos, st.vectorised);
    else
      driven_points(d, r, b.frame, pos, st.vectorised);
  }
  if (b.swept > 0.0f) {
    const Data::Sweep& sweep = d.sweeps[static_cast<size_t>(r.sweep)];
    const glm::vec3* swept =
        st.sweep.points.data() + static_cast<size_t>(static_cast<int>(ri) - sweep.first_ring) * sweep.columns;
    glm::vec3* out = pos.data() + r.first;
    if (b.swept >= 1.0f)
      std::copy(swept, swept + r.count, out);
    else
      for (uint32_t j = 0; j < r.count; ++j) out[j] += b.swept * (swept[j] - out[j]);
  }
}

}  // namespace

void deform(const Data& d, State& st, const rig::Pose& pose, std::span<glm::vec3> pos, bool muscles, bool contact) {
  const double t0 = steady_now_s();
  rig::forward_kinematics(d.skeleton, pose, st.world_from_joint);
  // With contact the arms keep off the body before anything follows them (loops, bands, hands).
  if (contact) clear_arms(d.contact, st.contact, st.world_from_joint);
  for (Chain& c : st.chains) c.update(st.world_from_joint);
  for (size_t i = 0; i < d.muscle_dofs.size(); ++i) {
    const auto& md = d.muscle_dofs[i];
    st.muscle_w[i] = muscles ? muscle_weights(pose.dof_rad[md.dof], md.theta0, md.theta_min, md.theta_max, md.falloff)
                             : glm::vec2(0.0f);
  }
  for (size_t b = 0; b < d.bands.size(); ++b)
    st.band_scale[b] = !st.band_scale_forced.empty()
                           ? st.band_scale_forced[b]
                           : d.bands[b].scale_at(chain_bend(st.chains[d.bands[b].chain]), muscles);
  star_frames(d, st, kHasAvx2Kernel && st.vectorised);
  for (size_t c = 0; c < st.chains.size(); ++c)
    if (st.chains[c].point.size() == 3) {
      st.tip_along[2 * c] = tip_direction(st.chains[c], 0, 1);
      st.tip_along[2 * c + 1] = tip_direction(st.chains[c], 1, 1);
    }
  const double t1 = steady_now_s();

  // A limb's driven rings come one after another and share S and the loop: one band frame.
  BandState band;
  for (size_t ri = 0; ri < d.rings.size(); ++ri) {
    const auto& r = d.rings[ri];
    Frame& f = st.frames[ri];
    switch (r.kind) {
      case RingKind::star: {
        StarRing s{f.origin, f.px, f.py, f.axis, f.rise(), f.along_per_normal};
        s.shear_z = s.a - r.rest_a;
        s.shear_q = s.rise * s.a - r.rest_rise * r.rest_a;
        s.centre = r.centre;
        s.scale = r.band >= 0 ? 1.0f + r.band_weight * (st.band_scale[r.band] - 1.0f) : 1.0f;
        const glm::vec2* w = muscles && r.muscle_count > 0 ? st.muscle_w.data() : nullptr;
        st.reach[ri] = kHasAvx2Kernel && st.vectorised ? star_points_avx2(d, r, s, w, pos.data() + r.first)
                                                       : star_points_scalar(d, r, s, w, pos.data() + r.first);
        if (r.tip_node >= 0) {
          const glm::vec3& along = st.tip_along[2 * static_cast<size_t>(r.chain) + (r.segment == 0 ? 0 : 1)];
          TipRound t;
          t.origin = f.origin;
          t.centre = st.chains[r.chain].point[r.tip_node];
          t.along = r.tip_node == 2 ? -along : along;
          t.w = t.origin - t.centre;
          t.w2 = glm::dot(t.w, t.w);
          t.origin_past = glm::dot(t.w, t.along);
          t.scale2 = s.scale * s.scale * (1.0f + 1e-5f);  // the margin: the initial pose stays put
          if (may_pass_joint(f, st.reach[ri], t))
            round_joint_tip(d, r, t, pos.data() + r.first, kHasAvx2Kernel && st.vectorised);
        }
        if (r.prev_star >= 0)
          crease(r, d.rings[r.prev_star], f, st.frames[r.prev_star], st.reach[ri], st.reach[r.prev_star], pos);
        break;
      }
      case RingKind::arc: {
        f = arc_frame(pos[r.from], pos[r.to], st.frames[r.up_ring].z, r.flip_up);
        for (uint32_t k = r.first; k < r.first + r.count; ++k) pos[k] = f.to_world({d.lx[k], d.ly[k], d.lz[k]});
        break;
      }
      case RingKind::driven: driven_ring(d, st, ri, pos, band); break;
    }
  }
  for (const auto& c : d.caps) {
    glm::vec3 sum(0.0f);
    for (uint32_t k = c.first; k < c.first + c.count; ++k) sum += pos[k];
    pos[c.vertex] = sum / static_cast<float>(c.count);
  }
  for (const auto& rg : d.rigid) {
    const rig::RigidTransform& w = st.world_from_joint[rg.joint];
    rigid_points(glm::mat3_cast(w.rotation), w.translation, d.rigid_local.data() + rg.first_local, rg.count,
                 pos.data() + rg.first_vertex, st.vectorised);
    if (rg.toe_joint < 0) continue;
    const rig::RigidTransform& toes = st.world_from_joint[rg.toe_joint];
    for (uint32_t k = rg.first_toe; k < rg.first_toe + rg.toe_count; ++k) {
      glm::vec3& p = pos[d.toe_vertex[k]];
      p += d.toe_weight[k] * (toes.apply(d.toe_local[k]) - p);
    }
  }
  const double t2 = steady_now_s();
  st.timings.joints_us = (t1 - t0) * 1e6;
  st.timings.points_us = (t2 - t1) * 1e6;
}

}  // namespace mimic::avatar::realtime_detail

namespace mimic::avatar {

float RealtimeBody::Data::Band::scale_at(float bend, bool muscles) const {
  const std::vector<float>& s = scale[muscles ? 1 : 0];
  if (bend_rad.empty() || bend <= bend_rad.front()) return s.empty() ? 1.0f : s.front();
  for (size_t i = 1; i < bend_rad.size(); ++i)
    if (bend <= bend_rad[i]) {
      const float t = (bend - bend_rad[i - 1]) / std::max(bend_rad[i] - bend_rad[i - 1], 1e-6f);
      return s[i - 1] + t * (s[i] - s[i - 1]);
    }
  return s.back();
}

bool RealtimeSkin::vectorised_kernel() { return realtime_detail::kHasAvx2Kernel; }

}  // namespace mimic::avatar
