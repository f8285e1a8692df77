// The fit's second step: the primitives' shapes to the reference surface (body_fit.h).
#include "mimic/avatar/body_fit.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <glm/gtc/quaternion.hpp>
#include <glm/gtx/euler_angles.hpp>

#include "body_fit_internal.h"
#include "mimic/avatar/body_overrides.h"
#include "mimic/avatar/mesh_check.h"

namespace mimic::avatar {

namespace {

using fit_detail::Girths;
using fit_detail::SkinnedLike;

constexpr int kParams = 6;                 // per primitive: centre x, y, z (joint frame), log semi-axes a, b, c
constexpr float kHuber_m = 0.004f;         // residuals beyond this count linearly
constexpr float kOutlier_m = 0.06f;        // correspondences further apart are left out
constexpr float kMinAgreement = 0.3f;      // cosine between the two surfaces' normals
constexpr float kMaxCentreStep_m = 0.01f;  // per iteration
constexpr float kMaxLogAxisStep = 0.15f;
constexpr float kMinAxis_m = 0.004f, kMaxAxis_m = 0.5f;

// One primitive in the fitted posture, world frame.
struct Geometry {
  glm::mat3 joint_rot{1.0f};  // world from its joint's frame
  glm::mat3 rot{1.0f};        // world from its own axes
  glm::vec3 center{0.0f}, axes{1.0f};
  float inv_r2 = 1, weight_norm = 1, bound2 = 0;
  GroupMask groups = 0;
  RigidPart part = RigidPart::none;
  bool hard = false;
  int param = -1;         // first of its kParams unknowns; -1 when not fitted
  bool mirrored = false;  // its unknowns are its left twin's, the centre's x mirrored
};

// Which unknowns move each primitive: kParams of its own, or (FitOptions::symmetric) a right
// primitive its left twin's, mirrored in x in the joints' frames as `symmetrised` mirrors them,
// so the body stays mirror-symmetric as it is fitted and written.
struct Unknowns {
  std::vector<int> first;  // per primitive; -1: not fitted (hard ellipsoids)
  std::vector<int> twin;   // per primitive, the other side's sharing its unknowns; -1: none
  std::vector<uint8_t> mirrored;
  int count = 0;

  Unknowns(const BodyModel& model, bool symmetric) {
    const size_t n = model.primitives.size();
    first.assign(n, -1), twin.assign(n, -1), mirrored.assign(n, 0);
    for (size_t k = 0; k < n; ++k) {
      const Primitive& p = model.primitives[k];
      if (p.kind == PrimitiveKind::ellipsoid) continue;
      if (symmetric && p.name.rfind("r_", 0) == 0)
        for (size_t l = 0; l < n; ++l)
          if (model.primitives[l].name == "l_" + p.name.substr(2) && model.primitives[l].kind == p.kind) {
            twin[k] = int(l), twin[l] = int(k), mirrored[k] = 1;
            break;
          }
      if (!mirrored[k]) first[k] = count, count += kParams;
    }
    for (size_t k = 0; k < n; ++k)
      if (mirrored[k]) first[k] = first[size_t(twin[k])];
  }

  // A frozen primitive freezes its twin: they share their unknowns.
  void tie(std::vector<uint8_t>& frozen) const {
    for (size_t k = 0; k < frozen.size(); ++k)
      if (twin[k] >= 0 && frozen[k]) frozen[size_t(twin[k])] = 1;
  }
};

glm::mat3 rotation_xyz(const glm::vec3& a) {
  return glm::mat3(glm::eulerAngleZ(a.z) * glm::eulerAngleY(a.y) * glm::eulerAngleX(a.x));
}

std::vector<Geometry> geometry(const BodyModel& model, const rig::Skeleton& s, const rig::Pose& pose,
                               const Unknowns& unknowns) {
  std::vector<rig::RigidTransform> world(s.joint_count());
  rig::forward_kinematics(s, pose, world);
  std::vector<Geometry> out;
  for (const Primitive& p : model.primitives) {
    Geometry g;
    const int j = s.find_joint(p.joint);
    PrimitiveState st = p.state;
    if (p.deformation) {
      const int d = s.find_dof(p.deformation->dof);
      if (d >= 0) {
        const rig::Dof& dof = s.dof(d);
        st = deformed_state(p.state, p.deformation->at_min, p.deformation->at_max, p.deformation->falloff,
                            pose.dof_rad[d], dof.rest_rad, dof.min_rad, dof.max_rad);
      }
    }
    const rig::RigidTransform w = j >= 0 ? world[j] : rig::RigidTransform{};
    g.joint_rot = glm::mat3_cast(w.rotation);
    g.rot = g.joint_rot * rotation_xyz(st.orientation_rad);
    g.center = w.apply(st.center_m);
    g.axes = st.semi_axes_m;
    const float r2 = p.influence * p.influence;
    const float base = 1.0f - 1.0f / r2;
    g.inv_r2 = 1.0f / r2;
    g.weight_norm = p.weight / (base * base * base);
    const float max_axis = std::max({g.axes.x, g.axes.y, g.axes.z});
    g.bound2 = r2 * max_axis * max_axis;
    g.groups = p.groups;
    g.part = p.part;
    g.hard = p.kind == PrimitiveKind::ellipsoid;
    g.param = unknowns.first[out.size()];
    g.mirrored = unknowns.mirrored[out.size()];
    out.push_back(g);
  }
  return out;
}

// How the surface near a point moves with the unknowns: per primitive, ∂F/∂θ / |∇F| (outward
// motion per unit of θ), and the surface's outward normal there.
struct Entry {
  int param = 0;
  float d[kParams] = {};
};
struct Handle {
  glm::vec3 normal{0.0f};
  uint32_t first = 0, count = 0;
  bool valid = false;
};

struct Linearisation {
  std::vector<glm::vec3> points;
  std::vector<Handle> handles;
  std::vector<Entry> entries;
  std::optional<TriangleTree> tree;  // the points, for nearest-handle look-ups

  void add(const std::vector<Geometry>& geo, const glm::vec3& p, GroupMask mask, RigidPart part) {
    Handle h;
    h.first = static_cast<uint32_t>(entries.size());
    glm::vec3 grad(0.0f);
    for (const Geometry& g : geo) {
      if (g.hard || (part != RigidPart::none ? g.part != part : !(g.groups & mask))) continue;
      const glm::vec3 d = p - g.center;
      if (glm::dot(d, d) > g.bound2) continue;
      const glm::vec3 q = (glm::transpose(g.rot) * d) / g.axes;
      const float u = 1.0f - glm::dot(q, q) * g.inv_r2;
      if (u <= 0.0f) continue;
      // term = wn·u³, u = 1 − |q|²/R²: ∂term/∂c = k·R·D⁻¹q (world), ∂term/∂log a_i = k·q_i².
      const float k = 6.0f * g.weight_norm * u * u * g.inv_r2;
      const glm::vec3 dc = g.rot * (q / g.axes) * k;
      grad -= dc;
      if (g.param < 0) continue;
      Entry e;
      e.param = g.param;
      glm::vec3 dc_joint = glm::transpose(g.joint_rot) * dc;
      if (g.mirrored) dc_joint.x = -dc_joint.x;
      for (int i = 0; i < 3; ++i) e.d[i] = dc_joint[i], e.d[3 + i] = k * q[i] * q[i];
      entries.push_back(e);
    }
    h.count = static_cast<uint32_t>(entries.size()) - h.first;
    const float len = glm::length(grad);
    h.valid = len > 1e-3f && h.count > 0;
    if (h.valid) {
      h.normal = -grad / len;
      for (uint32_t i = h.first; i < h.first + h.count; ++i)
        for (float& v : entries[i].d) v /= len;
    }
    points.push_back(p);
    handles.push_back(h);
  }
};

Linearisation linearise(const BodyModel& model, const SkinnedLike& s, const Unknowns& unknowns) {
  Linearisation lin;
  const std::vector<Geometry> geo = geometry(model, s.skin.skeleton(), s.pose, unknowns);
  for (const auto& ring : s.skin.contours())
    for (const glm::vec3& p : ring.points) lin.add(geo, p, ring.mask, RigidPart::none);
  const Mesh& mesh = s.skin.mesh();
  std::vector<uint8_t> seen(mesh.positions.size(), 0);
  for (const MeshPart& part : mesh.parts) {
    const auto rigid = rigid_part_from_name(part.name);
    if (!rigid || *rigid == RigidPart::none) continue;
    for (uint32_t t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t)
      for (int c = 0; c < 3; ++c) {
        const uint32_t v = mesh.indices[3 * t + c];
        if (!seen[v]) seen[v] = 1, lin.add(geo, mesh.positions[v], 0, *rigid);
      }
  }
  Mesh pts;
  pts.positions = lin.points;
  for (uint32_t i = 0; i < pts.positions.size(); ++i) pts.indices.insert(pts.indices.end(), {i, i, i});
  lin.tree.emplace(pts);
  return lin;
}

// Normal equations JᵀWJ δ = −JᵀWr of the point-to-plane residuals.
struct Normal {
  int n = 0;
  std::vector<double> a, b;
  explicit Normal(int unknowns) : n(unknowns), a(size_t(unknowns) * unknowns, 0.0), b(unknowns, 0.0) {}

  // A residual r whose derivative is `scale` times the handle's outward motion.
  void add(const Linearisation& lin, const Handle& h, double r, double scale) {
    const double w = std::abs(r) <= kHuber_m ? 1.0 : kHuber_m / std::abs(r);
    for (uint32_t i = h.first; i < h.first + h.count; ++i) {
      const Entry& e1 = lin.entries[i];
      for (int k1 = 0; k1 < kParams; ++k1) {
        const double j1 = scale * e1.d[k1];
        if (j1 == 0.0) continue;
        b[size_t(e1.param + k1)] -= w * j1 * r;
        double* row = &a[size_t(e1.param + k1) * n];
        for (uint32_t m = h.first; m < h.first + h.count; ++m) {
          const Entry& e2 = lin.entries[m];
          for (int k2 = 0; k2 < kParams; ++k2) row[e2.param + k2] += w * j1 * scale * e2.d[k2];
        }
      }
    }
  }

  // A residual r with the dense derivative row j, counted `weight` times (Huber beyond kHuber_m).
  void add_row(const std::vector<double>& j, double r, double weight) {
    const double w = weight * (std::abs(r) <= kHuber_m ? 1.0 : kHuber_m / std::abs(r));
    std::vector<int> nonzero;
    for (int i = 0; i < n; ++i)
      if (j[size_t(i)] != 0.0) nonzero.push_back(i);
    for (int i1 : nonzero) {
      b[size_t(i1)] -= w * j[size_t(i1)] * r;
      for (int i2 : nonzero) a[size_t(i1) * n + i2] += w * j[size_t(i1)] * j[size_t(i2)];
    }
  }
};

void add_residuals(Normal& ne, const Linearisation& lin, const Mesh& body, const TriangleTree& ref_tree,
                   const std::vector<SurfaceSample>& ref_samples, int samples) {
  // Body → reference: the body's point s moves along its normal; r = n_ref·(s − c).
  for (const SurfaceSample& s : sample_surface(body, samples, 7)) {
    const TriangleTree::Hit c = ref_tree.closest(s.point);
    const Handle& h = lin.handles[lin.tree->closest(s.point).triangle];
    const glm::vec3 n = ref_tree.normal(c.triangle);
    const float agree = glm::dot(n, h.normal);
    if (!h.valid || agree < kMinAgreement || c.distance_m > kOutlier_m) continue;
    ne.add(lin, h, glm::dot(n, s.point - c.point), agree);
  }
  // Reference → body: the body's nearest point q moves; r = n_q·(p − q).
  const TriangleTree body_tree(body);
  for (const SurfaceSample& p : ref_samples) {
    const TriangleTree::Hit q = body_tree.closest(p.point);
    const Handle& h = lin.handles[lin.tree->closest(q.point).triangle];
    const glm::vec3 n = body_tree.normal(q.triangle);
    const float agree = glm::dot(n, h.normal);
    if (!h.valid || agree < kMinAgreement || q.distance_m > kOutlier_m) continue;
    ne.add(lin, h, glm::dot(n, p.point - q.point), -agree);
  }
}

// The girths beyond their band: each residual is its excess radius (girth_excess_m). The tape is
// the convex hull of the slice's loops, so its length moves with the hull's corners: corner p
// moving by δp lengthens it by (û_in − û_out)·δp (the unit edges in and out of p), and the
// surface moving along its normal n by δ moves the corner within the plane by δ·n_p/|n_p|² (n_p:
// n projected into the plane).
void add_girth_residuals(Normal& ne, const Linearisation& lin, const Mesh& body, const Girths& ours,
                         const Girths& reference, const FitOptions& options) {
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  for (size_t g = 0; g < fit_detail::kGirths; ++g) {
    if (!ours.value[g] || !reference.value[g] || !ours.tape[g]) continue;
    const float r = fit_detail::girth_excess_m(*ours.value[g], *reference.value[g], options.girth_band);
    if (r == 0.0f) continue;
    const std::vector<glm::vec3> hull = tape_hull(body, *ours.tape[g]);
    const glm::vec3 k = glm::normalize(ours.tape[g]->normal);
    std::vector<double> row(size_t(ne.n), 0.0);
    for (size_t i = 0; i < hull.size() && hull.size() >= 3; ++i) {
      const glm::vec3 p = hull[i], in = hull[(i + hull.size() - 1) % hull.size()], out = hull[(i + 1) % hull.size()];
      const glm::vec3 lengthens = glm::normalize(p - in) + glm::normalize(p - out);
      const Handle& h = lin.handles[lin.tree->closest(p).triangle];
      if (!h.valid) continue;
      const glm::vec3 np = h.normal - glm::dot(h.normal, k) * k;
      // A surface nearly parallel to the plane would move the corner far: capped at twice.
      const float c = glm::dot(lengthens, np) / std::max(glm::dot(np, np), 0.25f) / two_pi;
      for (uint32_t e = h.first; e < h.first + h.count; ++e)
        for (int q = 0; q < kParams; ++q) row[size_t(lin.entries[e].param + q)] += double(c * lin.entries[e].d[q]);
    }
    ne.add_row(row, r, double(options.girth_weight) * options.samples);
  }
}

// (A + λ·diag(A) + ε) x = b by Cholesky, the unknowns marked `fixed` held at 0; false when not
// positive definite.
bool solve_damped(const Normal& ne, double lambda, const std::vector<uint8_t>& fixed, std::vector<double>& x) {
  const int n = ne.n;
  double trace = 0;
  for (int i = 0; i < n; ++i) trace += ne.a[size_t(i) * n + i];
  const double eps = 1e-6 * trace / std::max(n, 1) + 1e-12;
  std::vector<double> l(ne.a);
  for (int i = 0; i < n; ++i) l[size_t(i) * n + i] += lambda * ne.a[size_t(i) * n + i] + eps;
  for (int i = 0; i < n; ++i)
    if (fixed[size_t(i)])
      for (int k = 0; k < n; ++k) l[size_t(i) * n + k] = l[size_t(k) * n + i] = i == k ? 1.0 : 0.0;
  for (int j = 0; j < n; ++j) {
    double d = l[size_t(j) * n + j];
    for (int k = 0; k < j; ++k) d -= l[size_t(j) * n + k] * l[size_t(j) * n + k];
    if (!(d > 0)) return false;
    d = std::sqrt(d);
    l[size_t(j) * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      double s = l[size_t(i) * n + j];
      for (int k = 0; k < j; ++k) s -= l[size_t(i) * n + k] * l[size_t(j) * n + k];
      l[size_t(i) * n + j] = s / d;
    }
  }
  x = ne.b;
  for (int i = 0; i < n; ++i)
    if (fixed[size_t(i)]) x[size_t(i)] = 0;
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < i; ++k) x[i] -= l[size_t(i) * n + k] * x[k];
    x[i] /= l[size_t(i) * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    for (int k = i + 1; k < n; ++k) x[i] -= l[size_t(k) * n + i] * x[k];
    x[i] /= l[size_t(i) * n + i];
  }
  return true;
}

void move_state(PrimitiveState& st, const glm::vec3& dc, const glm::vec3& dlog) {
  st.center_m += dc;
  for (int i = 0; i < 3; ++i)
    st.semi_axes_m[i] = std::clamp(st.semi_axes_m[i] * std::exp(dlog[i]), kMinAxis_m, kMaxAxis_m);
}

// The model moved by the step x, except the primitives marked `frozen`.
BodyModel stepped(const BodyModel& model, const std::vector<double>& x, const std::vector<uint8_t>& frozen,
                  const Unknowns& unknowns) {
  BodyModel out = model;
  for (size_t k = 0; k < out.primitives.size(); ++k) {
    Primitive& p = out.primitives[k];
    const int param = unknowns.first[k];
    if (param < 0 || frozen[k]) continue;
    glm::vec3 dc, dl;
    for (int i = 0; i < 3; ++i) {
      dc[i] = std::clamp(float(x[size_t(param + i)]), -kMaxCentreStep_m, kMaxCentreStep_m);
      dl[i] = std::clamp(float(x[size_t(param + 3 + i)]), -kMaxLogAxisStep, kMaxLogAxisStep);
    }
    if (unknowns.mirrored[k]) dc.x = -dc.x;
    move_state(p.state, dc, dl);
    if (p.deformation) move_state(p.deformation->at_min, dc, dl), move_state(p.deformation->at_max, dc, dl);
  }
  return out;
}

// A body measured: its skin in the reference's posture and its distance both ways.
struct Measured {
  SkinnedLike skinned;
  PosedBody posed;
  SurfaceDistance distance;
  Girths girths;                  // when fitted (FitOptions::girth_weight)
  double girth_penalty_m = 0;     // their part of the score
  float largest_girth_error = 0;  // relative
  double score() const {
    return distance.body_to_reference.mean_m + distance.reference_to_body.mean_m + girth_penalty_m;
  }
  // Good enough to keep: closed, no more folds in any part and no more missed rays than `than`.
  bool sound(const Measured& than) const {
    return posed.closed && new_fold_parts(than).empty() && posed.missed_rays <= than.posed.missed_rays;
  }
  // Names of the mesh parts with more folds than in `than`.
  std::vector<std::string> new_fold_parts(const Measured& than) const {
    std::vector<std::string> out;
    for (size_t k = 0; k < posed.part_folds.size() && k < than.posed.part_folds.size(); ++k)
      if (posed.part_folds[k] > than.posed.part_folds[k]) out.push_back(posed.mesh.parts[k].name);
    return out;
  }
};

struct Context {
  const Mesh& reference;
  const BodyLandmarks& landmarks;
  const TriangleTree& ref_tree;
  const FitOptions& options;
  const Girths& ref_girths;

  Result<Measured> measure(const BodyModel& model) const {
    auto s = fit_detail::skin_like(model, landmarks, options.subdivision);
    if (!s) return tl::unexpected(s.error());
    Measured m{std::move(*s), {}, {}, {}, 0, 0};
    m.posed.mesh = m.skinned.skin.mesh();
    m.posed.landmarks = landmarks_from_skeleton(m.skinned.skin.skeleton(), m.skinned.pose);
    m.posed.pose = m.skinned.pose;
    m.posed.folds = count_folds(m.posed.mesh, 1e-5f, &m.posed.part_folds, &m.posed.fold_points);
    m.posed.closed = is_closed_oriented_manifold(analyze_topology(m.posed.mesh));
    m.posed.missed_rays = m.skinned.skin.stats().missed_rays;
    m.distance.body_to_reference = directed_distance(m.posed.mesh, m.posed.landmarks, ref_tree, options.samples);
    m.distance.reference_to_body = directed_distance(reference, landmarks, TriangleTree(m.posed.mesh), options.samples);
    if (options.girth_weight > 0) {
      m.girths = fit_detail::measure_girths(m.posed.mesh, m.posed.landmarks);
      m.girth_penalty_m = fit_detail::girth_penalty_m(m.girths, ref_girths, options, &m.largest_girth_error);
    }
    return m;
  }

  void report(const char* stage, int iteration, const Measured& m, bool accepted) const {
    if (options.progress)
      options.progress({stage, iteration, options.iterations, m.distance, accepted, m.largest_girth_error});
  }
};

// Marks the fitted primitives whose support reaches a fold of `m` that `than` did not have (none
// within 3 mm); false when none was left to mark.
bool freeze(const BodyModel& model, const Measured& m, const Measured& than, const Unknowns& unknowns,
            std::vector<uint8_t>& frozen) {
  const std::vector<Geometry> geo = geometry(model, m.skinned.skin.skeleton(), m.skinned.pose, unknowns);
  bool any = false;
  for (const glm::vec3& f : m.posed.fold_points) {
    bool old = false;
    for (const glm::vec3& g : than.posed.fold_points) old = old || glm::distance(f, g) < 0.003f;
    if (old) continue;
    for (size_t i = 0; i < geo.size(); ++i) {
      const glm::vec3 d = f - geo[i].center;
      if (geo[i].param >= 0 && !frozen[i] && glm::dot(d, d) < geo[i].bound2) frozen[i] = 1, any = true;
    }
  }
  return any;
}

// The unknowns of the frozen primitives.
std::vector<uint8_t> fixed_unknowns(const Unknowns& unknowns, const std::vector<uint8_t>& frozen) {
  std::vector<uint8_t> out(size_t(unknowns.count), 0);
  for (size_t i = 0; i < frozen.size(); ++i)
    if (frozen[i] && unknowns.first[i] >= 0) std::fill_n(out.begin() + unknowns.first[i], kParams, 1);
  return out;
}

// A primitive the options keep as it is.
bool held(const FitOptions& o, const Primitive& p) {
  if (p.part != RigidPart::none && (o.hold_rigid || !o.fit_rigid_shapes)) return true;
  const std::string left = p.name.rfind("r_", 0) == 0 ? "l_" + p.name.substr(2) : p.name;
  return std::find(o.held.begin(), o.held.end(), p.name) != o.held.end() ||
         std::find(o.held.begin(), o.held.end(), left) != o.held.end();
}

// Levenberg–Marquardt over the shapes; `cur` holds the best body so far.
void fit_shapes(const Context& ctx, BodyModel& body, Measured& cur, FitResult& result) {
  const std::vector<SurfaceSample> ref_samples = sample_surface(ctx.reference, ctx.options.samples, 3);
  const Unknowns unknowns(body, ctx.options.symmetric);
  double lambda = 1e-2;
  for (int it = 1; it <= ctx.options.iterations; ++it) {
    result.iterations = it;
    const Linearisation lin = linearise(body, cur.skinned, unknowns);
    Normal ne(unknowns.count);
    add_residuals(ne, lin, cur.posed.mesh, ctx.ref_tree, ref_samples, ctx.options.samples);
    if (ctx.options.girth_weight > 0)
      add_girth_residuals(ne, lin, cur.posed.mesh, cur.girths, ctx.ref_girths, ctx.options);
    bool improved = false, froze = false;
    // Primitives whose steps folded the skin stay where they are for the rest of this iteration.
    std::vector<uint8_t> frozen(body.primitives.size(), 0);
    for (size_t k = 0; k < body.primitives.size(); ++k) frozen[k] = held(ctx.options, body.primitives[k]);
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      unknowns.tie(frozen);
      std::vector<double> x;
      if (!solve_damped(ne, lambda, fixed_unknowns(unknowns, frozen), x)) {
        lambda *= 10;
        continue;
      }
      BodyModel candidate = stepped(body, x, frozen, unknowns);
      auto m = ctx.measure(candidate);
      improved = m && m->sound(cur) && m->score() < cur.score();
      if (m && !improved && m->posed.closed && m->score() < cur.score() &&
          freeze(candidate, *m, cur, unknowns, frozen)) {
        // A step that helps but folds the skin: again without the primitives that reach the folds.
        froze = true;
        ctx.report("shapes", it, *m, false);
        continue;
      }
      if (improved) {
        body = std::move(candidate);
        cur = std::move(*m);
        lambda = std::max(lambda / 3, 1e-5);
        result.accepted++;
      } else {
        lambda *= 4;
      }
      ctx.report("shapes", it, improved || !m ? cur : *m, improved);
    }
    if (!improved && !froze) break;  // no step of any damping helps: converged
  }
}

}  // namespace

Result<FitResult> fit_body(const BodyModel& start, const Mesh& reference_m, const BodyLandmarks& reference_landmarks,
                           const FitOptions& options) {
  if (reference_m.triangle_count() == 0)
    return fail(Errc::invalid_argument, "fit: the reference mesh has no triangles");
  if (options.samples < 100 || options.iterations < 0)
    return fail(Errc::invalid_argument, "fit: needs at least 100 samples and a non-negative iteration count");
  if (options.girth_weight < 0 || !(options.girth_band >= 0))
    return fail(Errc::invalid_argument, "fit: the girths' weight and band must not be negative");
  const TriangleTree ref_tree(reference_m);
  const Girths ref_girths =
      options.girth_weight > 0 ? fit_detail::measure_girths(reference_m, reference_landmarks) : Girths{};
  const Context ctx{reference_m, reference_landmarks, ref_tree, options, ref_girths};
  auto first = ctx.measure(start);
  if (!first) return tl::unexpected(first.error());
  Measured cur = std::move(*first);
  FitResult result;
  result.body = start;
  result.before = cur.distance;
  result.folds_before = cur.posed.folds;
  ctx.report("start", 0, cur, true);
  if (options.skeleton) {
    auto fitted = fit_skeleton(start, reference_landmarks, options.hold_rigid);
    if (!fitted) return tl::unexpected(fitted.error());
    auto m = ctx.measure(*fitted);
    if (!m) return tl::unexpected(m.error());
    // The skeleton is taken from the reference's joints even where the surface gets no nearer
    // yet (the shapes follow), as long as the skin stays sound.
    const bool keep = m->posed.closed && m->posed.missed_rays <= cur.posed.missed_rays;
    if (keep) result.body = std::move(*fitted), cur = std::move(*m);
    ctx.report("skeleton", 0, cur, keep);
  }
  if (options.symmetric) {
    // The shapes move both sides alike from here, so they start alike (the skeleton too).
    result.body = symmetrised(result.body);
    auto m = ctx.measure(result.body);
    if (!m) return tl::unexpected(m.error());
    cur = std::move(*m);
  }
  if (options.shapes) fit_shapes(ctx, result.body, cur, result);
  result.after = cur.distance;
  result.folds_after = cur.posed.folds;
  return result;
}

}  // namespace mimic::avatar
