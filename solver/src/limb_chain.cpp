#include "limb_chain.h"

#include <algorithm>
#include <cmath>

#include <glm/gtx/quaternion.hpp>

#include "fast_trig.h"
#include "mimic/solver/swing_twist.h"
#include "mimic/solver/two_bone_ik.h"

namespace mimic::solver::detail {

using rig::Skeleton;

namespace {

// Limits first, then closeness to the hinted swivel.
float chain_cost(const ChainSolution& c, float phi) { return 40.0f * c.violation + 0.1f * phi * phi; }

float decompose_clamped(const Skeleton& s, const int* dofs, int count, const glm::quat& q, std::span<const float> warm,
                        std::array<float, 3>& out) {
  std::array<glm::vec3, 3> axes;
  std::array<float, 3> lo{}, hi{};
  for (int i = 0; i < count; ++i) {
    const auto& f = s.dof(dofs[i]);
    axes[i] = f.axis, lo[i] = f.min_rad, hi[i] = f.max_rad;
    out[i] = warm[dofs[i]];
  }
  angles_from_rotation(q, std::span(axes.data(), count), std::span(out.data(), count), std::span(lo.data(), count),
                       std::span(hi.data(), count));
  float violation = 0;
  for (int i = 0; i < count; ++i) {
    const float v = std::clamp(out[i], lo[i], hi[i]);
    violation += std::abs(v - out[i]);
    out[i] = v;
  }
  return violation;
}

}  // namespace

ChainGeometry chain_geometry(const ChainInput& in, const glm::vec3& pole) {
  const Skeleton& s = *in.s;
  const SolverModel::Chain& ch = *in.ch;
  ChainGeometry g;
  TwoBoneIkJob tb;
  tb.start_m = in.start;
  tb.target_m = in.end_t->translation;
  tb.pole_dir = pole;
  tb.upper_m = ch.upper_m;
  tb.lower_m = ch.lower_m;
  const auto& flex = s.dof(ch.flex_dof);
  tb.min_bend_rad = std::max(0.0f, flex.min_rad);
  tb.max_bend_rad = std::max(tb.min_bend_rad, flex.max_rad);
  if (!tb.Run()) return g;
  const glm::vec3 x_w = glm::normalize(tb.mid_m - in.start);
  const glm::vec3 f = glm::normalize(tb.end_m - tb.mid_m);
  glm::vec3 b_w = perpendicular_part(f, x_w);
  const bool straight = glm::length(b_w) < 1e-3f;
  if (straight) {
    // Straight: the bend plane is free; keep the one the upper segment's sensor shows, else
    // the one the pole implies.
    if (in.upper_rot) b_w = perpendicular_part(*in.upper_rot * ch.bend_dir, x_w);
    if (glm::length(b_w) < 1e-4f) b_w = perpendicular_part(-pole, x_w);
    if (glm::length(b_w) < 1e-4f) b_w = perpendicular_part(in.parent_w->rotation * ch.bend_dir, x_w);
    if (glm::length(b_w) < 1e-4f) b_w = perpendicular_part(in.parent_w->rotation * ch.hinge, x_w);
  }
  b_w = glm::normalize(b_w);
  // A nearly straight limb may be over-extended (a bend below zero) instead: then the bend plane
  // turns over. Keep the plane whose hinge agrees with the hint.
  g.bend = detail::fast_atan2(glm::dot(f, b_w), glm::dot(f, x_w));
  const bool may_flip = flex.min_rad < 0 && g.bend <= -flex.min_rad;
  if (may_flip) {
    const glm::vec3 hint = in.last_bend ? glm::cross(x_w, *in.last_bend) : in.hinge_hint;
    if (glm::dot(glm::cross(x_w, b_w), hint) < 0) {
      b_w = -b_w;
      g.bend = detail::fast_atan2(glm::dot(f, b_w), glm::dot(f, x_w));
    }
  }
  const glm::vec3 h_w = glm::cross(x_w, b_w);
  const glm::mat3 world_m(x_w, b_w, h_w);
  const glm::mat3 rest_m(ch.upper_dir, ch.bend_dir, ch.hinge);
  g.upper_world = glm::normalize(glm::quat_cast(world_m * glm::transpose(rest_m)));
  g.bend_world = b_w;
  g.turns_with_swivel = !straight && !may_flip && glm::length(tb.target_m - tb.start_m) > 1e-4f;
  g.ok = true;
  return g;
}

namespace {

// The chain's DOFs from its geometry: the upper joint's from the upper segment, the bend, then
// what is left orients the hand or foot. `phi` and `give_up_at` as for solve_chain; `bend_rot`,
// when given, is the clamped bend's rotation about the hinge (the same for every swivel of a
// turning chain: the search takes its sine and cosine once).
ChainSolution chain_dofs(const ChainInput& in, const ChainGeometry& g, float phi, float give_up_at,
                         const glm::quat* bend_rot = nullptr) {
  const Skeleton& s = *in.s;
  const SolverModel::Chain& ch = *in.ch;
  const auto& flex = s.dof(ch.flex_dof);
  ChainSolution out;
  out.violation = decompose_clamped(s, ch.upper_dofs.data(), ch.upper_dof_count,
                                    glm::conjugate(in.parent_w->rotation) * g.upper_world, in.warm, out.upper);
  out.bend = std::clamp(g.bend, flex.min_rad, flex.max_rad);
  out.violation += std::abs(out.bend - g.bend);
  out.bend_world = g.bend_world;
  if (chain_cost(out, phi) >= give_up_at) return out;
  glm::quat upper_local(1, 0, 0, 0);
  for (int i = 0; i < ch.upper_dof_count; ++i)
    upper_local = upper_local * glm::angleAxis(out.upper[i], s.dof(ch.upper_dofs[i]).axis);
  const glm::quat mid_pre =
      in.parent_w->rotation * upper_local * (bend_rot ? *bend_rot : glm::angleAxis(out.bend, ch.hinge));
  out.violation += decompose_clamped(s, ch.end_dofs.data(), ch.end_dof_count,
                                     glm::conjugate(mid_pre) * in.end_t->rotation, in.warm, out.end);
  out.ok = true;
  return out;
}

}  // namespace

ChainSolution solve_chain(const ChainInput& in, const ChainGeometry& g) {
  if (!g.ok) return ChainSolution{};
  return chain_dofs(in, g, 0.0f, std::numeric_limits<float>::infinity());
}

ChainSolution solve_chain(const ChainInput& in, const glm::vec3& pole, float phi, float give_up_at) {
  const ChainGeometry g = chain_geometry(in, pole);
  if (!g.ok) return ChainSolution{};
  return chain_dofs(in, g, phi, give_up_at);
}

// `grid.samples` samples round the axis, then halving steps about the best. A bent limb at
// another swivel is the hinted one turned about the start→target axis (the middle joint circles
// it, the end stays): one rotation instead of a two-bone solve per candidate. The samples are tried nearest the hint
// first, so that a good one found early rules out the far ones by their swivel cost alone; the
// winner is the same as in sample order (the lowest cost, on a tie the first in that order).
ChainSolution search_swivel(const ChainInput& in, const ChainGeometry& hinted, const glm::vec3& e1, const glm::vec3& e2,
                            ChainSolution best, SwivelGrid grid) {
  const bool turns = hinted.ok && hinted.turns_with_swivel;
  const SolverModel::Chain& ch = *in.ch;
  const auto& flex = in.s->dof(ch.flex_dof);
  const glm::quat bend_rot = glm::angleAxis(std::clamp(hinted.bend, flex.min_rad, flex.max_rad), ch.hinge);
  const glm::vec3 axis = glm::normalize(in.end_t->translation - in.start);
  float best_phi = 0;
  float best_cost = chain_cost(best, 0.0f);
  int best_rank = 0;  // the hint's, then a sample's place in sample order (refinements come last)
  auto try_swivel = [&](float phi, int rank) {
    // chain_cost(·, phi) is at least the swivel's cost: past the best it cannot win, nor at a tie
    // with a sample that comes first.
    const float floor_cost = 0.1f * phi * phi;
    if (floor_cost > best_cost || (floor_cost == best_cost && rank > best_rank)) return;
    const float give_up_at =
        rank < best_rank ? std::nextafter(best_cost, std::numeric_limits<float>::infinity()) : best_cost;
    ChainSolution cand;
    if (turns) {
      const glm::quat turn = glm::angleAxis(phi, axis);
      ChainGeometry g = hinted;
      g.upper_world = glm::normalize(turn * hinted.upper_world);
      g.bend_world = turn * hinted.bend_world;
      cand = chain_dofs(in, g, phi, give_up_at, &bend_rot);
    } else {
      cand = solve_chain(in, std::cos(phi) * e1 + std::sin(phi) * e2, phi, give_up_at);
    }
    const float cost = chain_cost(cand, phi);
    if (cand.ok && (cost < best_cost || (cost == best_cost && rank < best_rank)))
      best = cand, best_cost = cost, best_phi = phi, best_rank = rank;
  };
  const int n = std::max(2, grid.samples);
  auto sample = [n](int k) {
    return 6.2831853f * static_cast<float>(k) / static_cast<float>(n) - (k > n / 2 ? 6.2831853f : 0.0f);
  };
  for (int k = 1; k < (n + 1) / 2; ++k) {  // ±1/n turn, ±2/n, …, then the half turn
    try_swivel(sample(k), k);
    try_swivel(sample(n - k), n - k);
  }
  if (n % 2 == 0) try_swivel(sample(n / 2), n / 2);
  for (float step = 6.2831853f / static_cast<float>(2 * n); step > grid.finest_rad; step *= 0.5f) {
    const float around = best_phi;
    try_swivel(around - step, n);
    try_swivel(around + step, n);
  }
  return best;
}

}  // namespace mimic::solver::detail
