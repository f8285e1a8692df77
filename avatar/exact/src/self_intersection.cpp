// Exact predicates (CGAL's Epick kernel: intervals, exact numbers when they cannot decide) for
// which triangles intersect and which side of a surface a vertex is; the distances are
// floating point, which a depth in millimetres can afford.
#include "mimic/avatar/self_intersection.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include "closed_parts.h"

namespace mimic::avatar {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Soup = std::vector<K::Triangle_3>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, Soup::const_iterator>>>;

// Triangles under (10 µm)² have no direction to crease with.
constexpr double kMinCreaseArea_m2 = 1e-10;

Point to_point(const glm::vec3& p) { return {p.x, p.y, p.z}; }

// Inside a closed surface by the parity of a ray's crossings, the majority of three rays: a ray
// through an edge or a vertex miscounts, three skew directions do not all do that.
bool inside(const Tree& tree, const Point& p) {
  static const K::Vector_3 kDirections[] = {{0.5773502691896258, 0.5773502691896257, 0.5773502691896259},
                                            {-0.31426968052735443, 0.8660254037844387, -0.38818879625104916},
                                            {0.2672612419124244, -0.5345224838248488, 0.8017837257372732}};
  int odd = 0;
  for (const auto& d : kDirections) odd += tree.number_of_intersected_primitives(K::Ray_3(p, p + d)) % 2 == 1;
  return odd >= 2;
}

}  // namespace

IntersectionRules IntersectionRules::default_body() {
  IntersectionRules r;
  r.by_design = {{"head", "neck"},
                 {"left_hand", "left_lower_arm"},
                 {"right_hand", "right_lower_arm"},
                 {"left_foot", "left_lower_leg"},
                 {"right_foot", "right_lower_leg"}};
  r.rigid = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};
  return r;
}

struct SelfIntersectionChecker::Impl {
  size_t vertex_count = 0;
  std::vector<uint32_t> indices;
  std::vector<uint32_t> part_of_triangle;
  std::vector<std::string> names;
  std::vector<std::vector<uint8_t>> by_design;  // part × part
  std::vector<uint8_t> rigid;                   // per part
  std::vector<exact_detail::ClosedPart> closed;
  std::vector<std::array<uint32_t, 2>> crease_edges;
  SurfaceMesh surface;  // the whole mesh's connectivity; a check copies it with its positions

  void count_pairs(std::span<const glm::vec3> positions, IntersectionReport& r,
                   std::vector<std::vector<size_t>>& pairs) const;
  void deepest(std::span<const glm::vec3> positions, const std::vector<std::vector<size_t>>& pairs,
               IntersectionReport& r) const;
};

Result<SelfIntersectionChecker> SelfIntersectionChecker::create(const Mesh& topology, const IntersectionRules& rules) {
  auto impl = std::make_unique<Impl>();
  Impl& d = *impl;
  d.vertex_count = topology.positions.size();
  d.indices = topology.indices;
  const size_t triangles = topology.triangle_count();
  for (uint32_t i : d.indices)
    if (i >= d.vertex_count) return fail(Errc::invalid_argument, "a triangle's index is past the vertices");
  const std::vector<MeshPart> parts = covering_parts(topology);
  d.part_of_triangle.assign(triangles, 0);
  std::vector<uint8_t> envelope(triangles, 1);
  for (uint32_t p = 0; p < parts.size(); ++p) {
    const MeshPart& part = parts[p];
    if (size_t(part.first_triangle) + part.triangle_count > triangles)
      return fail(Errc::invalid_argument, "part '" + part.name + "' runs past the triangles");
    d.names.push_back(part.name);
    const bool rigid = std::find(rules.rigid.begin(), rules.rigid.end(), part.name) != rules.rigid.end();
    d.rigid.push_back(rigid);
    for (uint32_t t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t)
      d.part_of_triangle[t] = p, envelope[t] = !rigid;
    d.closed.push_back(exact_detail::close_part(d.indices, d.vertex_count, part.first_triangle, part.triangle_count));
  }
  d.by_design.assign(parts.size(), std::vector<uint8_t>(parts.size(), 0));
  for (const auto& [a, b] : rules.by_design) {
    auto ia = std::find(d.names.begin(), d.names.end(), a), ib = std::find(d.names.begin(), d.names.end(), b);
    if (ia == d.names.end() || ib == d.names.end()) continue;
    const size_t pa = size_t(ia - d.names.begin()), pb = size_t(ib - d.names.begin());
    d.by_design[pa][pb] = d.by_design[pb][pa] = 1;
  }
  d.crease_edges = exact_detail::shared_edges(d.indices, envelope);

  for (size_t v = 0; v < d.vertex_count; ++v) d.surface.add_vertex(to_point(topology.positions[v]));
  for (size_t t = 0; t < triangles; ++t) {
    const auto f =
        d.surface.add_face(SurfaceMesh::Vertex_index(d.indices[3 * t]), SurfaceMesh::Vertex_index(d.indices[3 * t + 1]),
                           SurfaceMesh::Vertex_index(d.indices[3 * t + 2]));
    // Face indices are then the triangles' own; a triangle that cannot join (an edge used
    // three times, or twice the same way) leaves the mesh a non-manifold we do not check.
    if (f == SurfaceMesh::null_face() || size_t(f) != t)
      return fail(Errc::invalid_argument, "triangle " + std::to_string(t) + " does not make a manifold surface");
  }
  return SelfIntersectionChecker(std::move(impl));
}

void SelfIntersectionChecker::Impl::count_pairs(std::span<const glm::vec3> positions, IntersectionReport& r,
                                                std::vector<std::vector<size_t>>& pairs) const {
  SurfaceMesh mesh = surface;
  for (size_t v = 0; v < vertex_count; ++v) mesh.point(SurfaceMesh::Vertex_index(uint32_t(v))) = to_point(positions[v]);
  std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> found;
  CGAL::Polygon_mesh_processing::self_intersections(mesh, std::back_inserter(found));
  pairs.assign(names.size(), std::vector<size_t>(names.size(), 0));
  r.triangle_pairs.reserve(found.size());
  for (const auto& [f, g] : found) {
    r.triangle_pairs.emplace_back(uint32_t(f), uint32_t(g));
    uint32_t a = part_of_triangle[size_t(f)], b = part_of_triangle[size_t(g)];
    if (a > b) std::swap(a, b);
    ++pairs[a][b];
    if (a == b)
      ++r.fold_pairs;
    else if (by_design[a][b])
      ++r.by_design_pairs;
    else
      ++r.between_pairs;
  }
  for (size_t a = 0; a < names.size(); ++a)
    for (size_t b = a; b < names.size(); ++b)
      if (pairs[a][b] > 0) r.by_parts.push_back({names[a], names[b], pairs[a][b], by_design[a][b] != 0});
  std::stable_sort(r.by_parts.begin(), r.by_parts.end(),
                   [](const PartPairCount& x, const PartPairCount& y) { return x.pairs > y.pairs; });
}

// Only parts whose triangles cross can be inside one another: the pieces of one envelope are
// joined, so a piece cannot get into another without crossing its surface (or folding through
// itself, which the folds count).
void SelfIntersectionChecker::Impl::deepest(std::span<const glm::vec3> positions,
                                            const std::vector<std::vector<size_t>>& pairs,
                                            IntersectionReport& r) const {
  for (size_t b = 0; b < names.size(); ++b) {
    std::vector<size_t> crossing;
    for (size_t a = 0; a < names.size(); ++a)
      if (a != b && !by_design[a][b] && pairs[std::min(a, b)][std::max(a, b)] > 0) crossing.push_back(a);
    if (crossing.empty()) continue;
    const exact_detail::ClosedPart& part = closed[b];
    std::vector<Point> centroids;
    for (const auto& loop : part.loops) {
      glm::dvec3 sum(0);
      for (uint32_t v : loop) sum += glm::dvec3(positions[v]);
      sum /= double(loop.size());
      centroids.emplace_back(sum.x, sum.y, sum.z);
    }
    auto corner = [&](uint32_t i) { return i < vertex_count ? to_point(positions[i]) : centroids[i - vertex_count]; };
    Soup soup;
    for (const auto& t : part.triangles) soup.emplace_back(corner(t[0]), corner(t[1]), corner(t[2]));
    Tree tree(soup.begin(), soup.end());
    tree.accelerate_distance_queries();
    const CGAL::Bbox_3 box = tree.bbox();
    for (size_t a : crossing)
      for (uint32_t v : closed[a].vertices) {
        // A vertex the two parts share lies on both surfaces: depth 0.
        if (std::binary_search(part.vertices.begin(), part.vertices.end(), v)) continue;
        const Point p = to_point(positions[v]);
        if (!CGAL::do_overlap(box, p.bbox()) || !inside(tree, p)) continue;
        const double depth = std::sqrt(tree.squared_distance(p));
        if (depth > r.deepest_m) r.deepest_m = depth, r.deepest_part = names[a], r.deepest_inside = names[b];
        if (!rigid[a] && !rigid[b] && depth > r.deepest_envelope_m)
          r.deepest_envelope_m = depth, r.deepest_envelope_part = names[a], r.deepest_envelope_inside = names[b];
      }
  }
}

IntersectionReport SelfIntersectionChecker::check(std::span<const glm::vec3> positions) const {
  const Impl& d = *impl_;
  IntersectionReport r;
  if (positions.size() < d.vertex_count) return r;
  r.triangles = d.indices.size() / 3;
  std::vector<std::vector<size_t>> pairs;
  d.count_pairs(positions, r, pairs);
  d.deepest(positions, pairs, r);
  size_t worst = d.crease_edges.size();
  const double crease_rad =
      exact_detail::sharpest_crease(positions, d.indices, d.crease_edges, kMinCreaseArea_m2, worst);
  r.sharpest_crease_deg = crease_rad * 180.0 / M_PI;
  if (worst < d.crease_edges.size()) r.crease_part = d.names[d.part_of_triangle[d.crease_edges[worst][0]]];
  return r;
}

size_t SelfIntersectionChecker::part_count() const { return impl_->names.size(); }

SelfIntersectionChecker::SelfIntersectionChecker(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SelfIntersectionChecker::SelfIntersectionChecker(SelfIntersectionChecker&&) noexcept = default;
SelfIntersectionChecker& SelfIntersectionChecker::operator=(SelfIntersectionChecker&&) noexcept = default;
SelfIntersectionChecker::~SelfIntersectionChecker() = default;

}  // namespace mimic::avatar
