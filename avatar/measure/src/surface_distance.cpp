#include "mimic/avatar/surface_distance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <nlohmann/json.hpp>

namespace mimic::avatar {

namespace {

constexpr uint32_t kLeafSize = 4;

float box_distance2(const glm::vec3& p, const glm::vec3& lo, const glm::vec3& hi) {
  const glm::vec3 d = glm::max(glm::max(lo - p, p - hi), glm::vec3(0.0f));
  return glm::dot(d, d);
}

// splitmix64: a fixed, portable stream (std::uniform_real_distribution differs between
// standard libraries, and the samples must be the same everywhere).
struct SplitMix {
  uint64_t state;
  double next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
  }
};

float segment_distance2(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b) {
  const glm::vec3 ab = b - a;
  const float len2 = glm::dot(ab, ab);
  const float t = len2 > 0.0f ? std::clamp(glm::dot(p - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
  const glm::vec3 d = p - (a + t * ab);
  return glm::dot(d, d);
}

}  // namespace

glm::vec3 closest_point_on_triangle(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  // Ericson, Real-Time Collision Detection §5.1.5: which Voronoi region of the triangle p is in.
  const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return a;
  const glm::vec3 bp = p - b;
  const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0f && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) return a + (d1 / (d1 - d3)) * ab;
  const glm::vec3 cp = p - c;
  const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0f && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) return a + (d2 / (d2 - d6)) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const float sum = va + vb + vc;
  if (!(std::abs(sum) > 0.0f)) return a;  // degenerate (collinear) triangle past the edge tests
  const float v = vb / sum, w = vc / sum;
  return a + v * ab + w * ac;
}

TriangleTree::TriangleTree(const Mesh& mesh) {
  const size_t n = mesh.triangle_count();
  a_.resize(n), b_.resize(n), c_.resize(n), normals_.resize(n), order_.resize(n);
  std::vector<glm::vec3> centroids(n);
  for (size_t t = 0; t < n; ++t) {
    a_[t] = mesh.positions[mesh.indices[3 * t]];
    b_[t] = mesh.positions[mesh.indices[3 * t + 1]];
    c_[t] = mesh.positions[mesh.indices[3 * t + 2]];
    const glm::vec3 cr = glm::cross(b_[t] - a_[t], c_[t] - a_[t]);
    const float len = glm::length(cr);
    normals_[t] = len > 0.0f ? cr / len : glm::vec3(0.0f);
    centroids[t] = (a_[t] + b_[t] + c_[t]) / 3.0f;
    order_[t] = static_cast<uint32_t>(t);
  }
  nodes_.reserve(2 * n / kLeafSize + 2);
  if (n > 0) build(0, static_cast<uint32_t>(n), centroids);
}

uint32_t TriangleTree::build(uint32_t first, uint32_t count, std::vector<glm::vec3>& centroids) {
  const auto index = static_cast<uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Node node;
  node.lo = glm::vec3(std::numeric_limits<float>::infinity());
  node.hi = -node.lo;
  glm::vec3 clo = node.lo, chi = node.hi;
  for (uint32_t i = first; i < first + count; ++i) {
    const uint32_t t = order_[i];
    node.lo = glm::min(node.lo, glm::min(a_[t], glm::min(b_[t], c_[t])));
    node.hi = glm::max(node.hi, glm::max(a_[t], glm::max(b_[t], c_[t])));
    clo = glm::min(clo, centroids[t]);
    chi = glm::max(chi, centroids[t]);
  }
  node.first = first;
  node.count = count;
  if (count > kLeafSize) {
    // Median split along the widest extent of the centroids.
    const glm::vec3 ext = chi - clo;
    const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
    const uint32_t half = count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                     [&](uint32_t x, uint32_t y) { return centroids[x][axis] < centroids[y][axis]; });
    node.count = 0;
    node.left = build(first, half, centroids);
    node.right = build(first + half, count - half, centroids);
  }
  nodes_[index] = node;
  return index;
}

TriangleTree::Hit TriangleTree::closest(const glm::vec3& p) const {
  Hit best;
  if (nodes_.empty()) return best;
  float best_d2 = std::numeric_limits<float>::infinity();
  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (box_distance2(p, node.lo, node.hi) >= best_d2) continue;
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const uint32_t t = order_[i];
        const glm::vec3 q = closest_point_on_triangle(p, a_[t], b_[t], c_[t]);
        const float d2 = glm::dot(q - p, q - p);
        if (d2 < best_d2) {
          best_d2 = d2;
          best.point = q;
          best.triangle = t;
        }
      }
      continue;
    }
    // Nearer child last, so it is searched first. The depth is about log2(n / 4): 64 is plenty.
    const float dl = box_distance2(p, nodes_[node.left].lo, nodes_[node.left].hi);
    const float dr = box_distance2(p, nodes_[node.right].lo, nodes_[node.right].hi);
    const bool left_first = dl <= dr;
    if (top + 2 > 64) continue;
    stack[top++] = left_first ? node.right : node.left;
    stack[top++] = left_first ? node.left : node.right;
  }
  best.distance_m = std::sqrt(best_d2);
  return best;
}

std::vector<SurfaceSample> sample_surface(const Mesh& mesh, int count, uint64_t seed) {
  std::vector<SurfaceSample> out;
  const size_t n = mesh.triangle_count();
  if (n == 0 || count <= 0) return out;
  std::vector<double> cumulative(n);
  double total = 0;
  for (size_t t = 0; t < n; ++t) {
    const glm::dvec3 a(mesh.positions[mesh.indices[3 * t]]), b(mesh.positions[mesh.indices[3 * t + 1]]),
        c(mesh.positions[mesh.indices[3 * t + 2]]);
    total += 0.5 * glm::length(glm::cross(b - a, c - a));
    cumulative[t] = total;
  }
  if (!(total > 0)) return out;
  SplitMix rng{seed};
  out.reserve(static_cast<size_t>(count));
  for (int k = 0; k < count; ++k) {
    // Stratified: sample k falls in the k-th equal slice of the cumulative area.
    const double u = (k + rng.next()) / count * total;
    const auto it = std::lower_bound(cumulative.begin(), cumulative.end(), u);
    const auto t = static_cast<uint32_t>(std::min<size_t>(static_cast<size_t>(it - cumulative.begin()), n - 1));
    double r1 = std::sqrt(rng.next()), r2 = rng.next();
    const glm::vec3 a = mesh.positions[mesh.indices[3 * t]], b = mesh.positions[mesh.indices[3 * t + 1]],
                    c = mesh.positions[mesh.indices[3 * t + 2]];
    const auto wa = static_cast<float>(1 - r1), wb = static_cast<float>(r1 * (1 - r2)),
               wc = static_cast<float>(r1 * r2);
    out.push_back({wa * a + wb * b + wc * c, t});
  }
  return out;
}

const char* body_region_name(BodyRegion r) {
  static constexpr const char* kNames[kBodyRegionCount] = {"head", "torso", "arms", "hands", "legs", "feet"};
  return kNames[static_cast<int>(r)];
}

RegionClassifier::RegionClassifier(const BodyLandmarks& lm) {
  auto add = [&](glm::vec3 a, glm::vec3 b, BodyRegion r) { segments_.push_back({a, b, r}); };
  glm::vec3 prev = lm.pelvis_m;
  for (const glm::vec3& s : lm.spine_m) add(prev, s, BodyRegion::torso), prev = s;
  add(prev, lm.neck_m, BodyRegion::torso);
  add(lm.neck_m, lm.head_m, BodyRegion::head);
  add(lm.head_m, lm.head_top_m, BodyRegion::head);
  for (const LimbLandmarks* limb : {&lm.left, &lm.right}) {
    add(limb->shoulder_m, limb->elbow_m, BodyRegion::arms);
    add(limb->elbow_m, limb->wrist_m, BodyRegion::arms);
    add(limb->wrist_m, limb->wrist_m + 0.75f * (limb->wrist_m - limb->elbow_m), BodyRegion::hands);
    add(limb->hip_m, limb->knee_m, BodyRegion::legs);
    add(limb->knee_m, limb->ankle_m, BodyRegion::legs);
    const float shin = glm::length(limb->knee_m - limb->ankle_m);
    add(limb->ankle_m, {limb->ankle_m.x, lm.ground_y_m, limb->ankle_m.z + 0.45f * shin}, BodyRegion::feet);
  }
  // The hips: pelvis to each hip joint is torso.
  add(lm.pelvis_m, lm.left.hip_m, BodyRegion::torso);
  add(lm.pelvis_m, lm.right.hip_m, BodyRegion::torso);
}

BodyRegion RegionClassifier::classify(const glm::vec3& p) const {
  BodyRegion best = BodyRegion::torso;
  float best_d2 = std::numeric_limits<float>::infinity();
  for (const Segment& s : segments_) {
    const float d2 = segment_distance2(p, s.a, s.b);
    if (d2 < best_d2) best_d2 = d2, best = s.region;
  }
  return best;
}

double SurfaceDistance::worst_mean_m() const { return std::max(body_to_reference.mean_m, reference_to_body.mean_m); }

DirectedDistance directed_distance(const Mesh& from, const BodyLandmarks& from_landmarks, const TriangleTree& to,
                                   int samples) {
  DirectedDistance d;
  if (to.triangle_count() == 0) return d;
  const RegionClassifier regions(from_landmarks);
  std::array<double, kBodyRegionCount> sums{};
  double sum = 0, sum2 = 0;
  for (const SurfaceSample& s : sample_surface(from, samples)) {
    const double dist = to.closest(s.point).distance_m;
    const int r = static_cast<int>(regions.classify(s.point));
    sums[r] += dist;
    d.region_samples[r]++;
    sum += dist;
    sum2 += dist * dist;
    d.max_m = std::max(d.max_m, dist);
    d.samples++;
  }
  if (d.samples > 0) {
    d.mean_m = sum / d.samples;
    d.rms_m = std::sqrt(sum2 / d.samples);
  }
  for (int r = 0; r < kBodyRegionCount; ++r)
    d.region_mean_m[r] = d.region_samples[r] ? sums[r] / d.region_samples[r] : 0;
  return d;
}

SurfaceDistance surface_distance(const Mesh& body, const BodyLandmarks& body_landmarks, const Mesh& reference,
                                 const BodyLandmarks& reference_landmarks, int samples) {
  SurfaceDistance d;
  d.body_to_reference = directed_distance(body, body_landmarks, TriangleTree(reference), samples);
  d.reference_to_body = directed_distance(reference, reference_landmarks, TriangleTree(body), samples);
  return d;
}

std::string format_surface_distance(const SurfaceDistance& d) {
  std::string out = "surface distance (mm)     body -> reference   reference -> body\n";
  char line[160];
  auto row = [&](const char* name, double a, double b) {
    std::snprintf(line, sizeof line, "  %-22s %16.2f %19.2f\n", name, a * 1e3, b * 1e3);
    out += line;
  };
  row("mean", d.body_to_reference.mean_m, d.reference_to_body.mean_m);
  row("rms", d.body_to_reference.rms_m, d.reference_to_body.rms_m);
  row("max", d.body_to_reference.max_m, d.reference_to_body.max_m);
  for (int r = 0; r < kBodyRegionCount; ++r)
    row((std::string("mean, ") + body_region_name(static_cast<BodyRegion>(r))).c_str(),
        d.body_to_reference.region_mean_m[r], d.reference_to_body.region_mean_m[r]);
  return out;
}

std::string surface_distance_json(const SurfaceDistance& d) {
  auto mm = [](double m) { return std::round(m * 1e5) / 1e2; };  // 0.01 mm
  auto side = [&](const DirectedDistance& s) {
    nlohmann::json regions = nlohmann::json::object();
    for (int r = 0; r < kBodyRegionCount; ++r)
      if (s.region_samples[r] > 0) regions[body_region_name(static_cast<BodyRegion>(r))] = mm(s.region_mean_m[r]);
    return nlohmann::json{{"mean", mm(s.mean_m)}, {"rms", mm(s.rms_m)}, {"max", mm(s.max_m)}, {"regions", regions}};
  };
  const nlohmann::json j{{"samples", d.body_to_reference.samples},
                         {"body_to_reference_mm", side(d.body_to_reference)},
                         {"reference_to_body_mm", side(d.reference_to_body)}};
  return j.dump();
}

}  // namespace mimic::avatar
