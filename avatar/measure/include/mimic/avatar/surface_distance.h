// Surface distance between two body meshes: how far each surface lies from the other, both ways,
// overall and per body region. `mimic compare` reports it and `mimic fit` minimises it.
//
// Distances are exact point-to-triangle distances (closest point on the triangle, Ericson's
// region test), found through a bounding volume hierarchy over the triangles. The points a
// direction is averaged over are samples spread over the surface in proportion to area
// (stratified along the cumulative area, fixed seed), so a finely meshed face counts no more than
// a coarsely meshed back: "mean distance body → reference" is the area-average over the body's
// surface of the distance to the reference surface.
//
// Regions are defined from the skeleton: a point belongs to the region of the nearest bone
// segment of the landmarks (body_region_of): head (neck → head → head top, so the neck counts
// as head), torso (pelvis → spine → neck), arms (shoulder → elbow → wrist), hands (wrist onward
// by 0.75 of the forearm's length), legs (hip → knee → ankle) and feet (ankle to a point at
// the ground 0.45 of the shin's length forward, +Z). Each side's samples are classified with
// its own landmarks.
//
// Metres throughout, +Y up, the body faces +Z.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh.h"

namespace mimic::avatar {

// Closest point to p on triangle abc (degenerate triangles are allowed).
glm::vec3 closest_point_on_triangle(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c);

// Closest-point queries on a triangle mesh. Keeps its own copy of the triangles.
class TriangleTree {
 public:
  explicit TriangleTree(const Mesh& mesh);

  struct Hit {
    glm::vec3 point{0.0f};
    float distance_m = -1.0f;  // < 0: the mesh has no triangles
    uint32_t triangle = 0;
  };
  Hit closest(const glm::vec3& p) const;
  // Unit normal of triangle t (counter-clockwise seen from outside: pointing out).
  glm::vec3 normal(uint32_t t) const { return normals_[t]; }
  size_t triangle_count() const { return normals_.size(); }

 private:
  struct Node {
    glm::vec3 lo{0.0f}, hi{0.0f};
    uint32_t first = 0, count = 0;  // leaf: triangles order_[first, first + count); else children
    uint32_t left = 0, right = 0;
  };
  uint32_t build(uint32_t first, uint32_t count, std::vector<glm::vec3>& centroids);
  std::vector<glm::vec3> a_, b_, c_, normals_;
  std::vector<uint32_t> order_;
  std::vector<Node> nodes_;
};

struct SurfaceSample {
  glm::vec3 point{0.0f};
  uint32_t triangle = 0;
};
// `count` samples spread over the mesh in proportion to triangle area (deterministic for a seed).
std::vector<SurfaceSample> sample_surface(const Mesh& mesh, int count, uint64_t seed = 1);

enum class BodyRegion : uint8_t { head, torso, arms, hands, legs, feet };
inline constexpr int kBodyRegionCount = 6;
const char* body_region_name(BodyRegion r);

// The region of the bone segment of `landmarks` nearest to p (see the top of this file).
class RegionClassifier {
 public:
  explicit RegionClassifier(const BodyLandmarks& landmarks);
  BodyRegion classify(const glm::vec3& p) const;

 private:
  struct Segment {
    glm::vec3 a{0.0f}, b{0.0f};
    BodyRegion region = BodyRegion::torso;
  };
  std::vector<Segment> segments_;
};

// One direction's distances (from the samples of one surface to the other surface).
struct DirectedDistance {
  int samples = 0;
  double mean_m = 0, rms_m = 0, max_m = 0;
  std::array<double, kBodyRegionCount> region_mean_m{};
  std::array<int, kBodyRegionCount> region_samples{};
};

struct SurfaceDistance {
  DirectedDistance body_to_reference;
  DirectedDistance reference_to_body;
  // The larger of the two means: what "within X mm both ways" bounds.
  double worst_mean_m() const;
};

inline constexpr int kDefaultDistanceSamples = 20000;

// Distances from `samples` area-weighted samples of `from` to the surface of `to`, classified
// into regions with `from_landmarks`.
DirectedDistance directed_distance(const Mesh& from, const BodyLandmarks& from_landmarks, const TriangleTree& to,
                                   int samples = kDefaultDistanceSamples);
SurfaceDistance surface_distance(const Mesh& body, const BodyLandmarks& body_landmarks, const Mesh& reference,
                                 const BodyLandmarks& reference_landmarks, int samples = kDefaultDistanceSamples);

// A text table (region, body → reference mm, reference → body mm) and a JSON object
// {"samples": n, "body_to_reference_mm": {"mean", "rms", "max", "regions": {"head": …}},
//  "reference_to_body_mm": {…}}.
std::string format_surface_distance(const SurfaceDistance& d);
std::string surface_distance_json(const SurfaceDistance& d);

}  // namespace mimic::avatar
