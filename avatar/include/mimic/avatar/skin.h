// The implicit skin (the full method): every frame, the contours of a ContourLayout
// (contour_layout.h) are ray-cast on the body's implicit (metaball iso-)surface and turned into
// one closed envelope plus rigid head, hands and feet (the paper's method, §3 of the design).
// RealtimeSkin (realtime_skin.h) is the other method: contours measured once, then moved.
//
//   FK → primitives moved and deformed → contours (star-shaped ray casting around the links,
//   joint-angle driven planes, boundary-driven rings at the junctions, bridges across the crotch
//   and over the shoulders) → cubic B-spline smoothing (closed around, open along) →
//   triangles, with one index array fixed at construction.
//
// Envelope topology (branching generalised cylinders): a torso stack whose bottom (crotch) ring
// splits into two leg loops sharing a crotch bridge; whose top (chest) ring splits into two arm
// loops and a neck loop sharing bridges over the shoulders. Limbs start with boundary-driven
// rings from their loop, so shared boundary points make the stitch exact: no cracks, no
// T-joints. Neck, wrists and ankles are capped; the rigid head, hands and feet cover them.
//
// Output: metres, +Y up, the body faces +Z; parts: the eleven skin pieces (neck, upper_torso,
// lower_torso, left/right upper/lower arm and leg), head, left/right hand and foot.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mimic/avatar/body_field.h"
#include "mimic/avatar/body_model.h"
#include "mimic/avatar/contour_layout.h"
#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"

namespace mimic::avatar {

struct SkinOptions {
  // 0: contour points are the vertices, no smoothing (the mesh the realtime method moves,
  // realtime_skin.h, without ray casting).
  // n ≥ 1: cubic B-spline smoothing, n samples per control span in both directions.
  int subdivision = 1;
  bool rigid_parts = true;  // head, hands, feet
  bool normals = true;      // area-weighted vertex normals every frame (files, renderers);
                            // a server that streams joint values can leave them off
};

// Wall-clock time of each stage of the last evaluate(), microseconds.
struct SkinTimings {
  double fk_us = 0, deform_us = 0, contours_us = 0, bspline_us = 0, stitch_us = 0;
  double normals_us = 0;  // vertex normals, when SkinOptions::normals (for renderers and files)
  double total_us() const { return fk_us + deform_us + contours_us + bspline_us + stitch_us + normals_us; }
};

struct SkinStats {
  int contours = 0;       // rings and bridges sampled per frame
  int rays = 0;           // rays cast per frame
  int missed_rays = 0;    // rays that found no surface last frame (placed by fallback)
  int windowed_rays = 0;  // boundary-driven rays whose surface lay outside their window around
                          // P last frame (placed at the window's nearer end)
};

class ImplicitSkin {
 public:
  // Builds the contour layout for the model (its own skeleton) and evaluates the zero posture.
  static Result<ImplicitSkin> create(const BodyModel& model, const SkinOptions& options = {});
  // Same, with a skeleton other than the model's (e.g. fitted to a performer); it must have the
  // model's joints and DOFs.
  static Result<ImplicitSkin> create(const BodyModel& model, const rig::Skeleton& skeleton,
                                     const SkinOptions& options = {});
  // A skin of a layout already built (from this model's primitives and the layout's skeleton);
  // the layout fixes the subdivision and rigid parts, `normals` is SkinOptions::normals.
  static Result<ImplicitSkin> create(const BodyModel& model, const ContourLayout& layout, bool normals = true);

  ImplicitSkin(ImplicitSkin&&) noexcept;
  ImplicitSkin& operator=(ImplicitSkin&&) noexcept;
  ~ImplicitSkin();

  // Whole pipeline for one pose; afterwards mesh() holds the new positions. Never allocates.
  void evaluate(const rig::Pose& pose);

  const Mesh& mesh() const;
  const ContourLayout& layout() const;
  // The contour (control) points of the last frame, metres, world frame, one per control point
  // of the layout (its rings' slots; at subdivision 0 the mesh's first vertices).
  std::span<const glm::vec3> control_points() const;
  const rig::Skeleton& skeleton() const;
  const BodyField& field() const;  // the primitives of the last evaluated pose
  const SkinTimings& timings() const;
  const SkinStats& stats() const;

  // Contour rings of the last frame, for inspection and tests: each ring's points (control
  // points, before smoothing) with the group mask its rays were cast in and, for star rings,
  // the ray origin; the points of boundary-driven and bridge rings come from rays too.
  struct ContourView {
    std::string name;
    GroupMask mask = 0;
    std::vector<glm::vec3> points;
    std::vector<glm::vec3> ray_origins;  // one per point
    std::vector<uint8_t> from_ray;       // 1 where the point is a ray hit (0: shared or fallback)
    // Boundary-driven rings: each point's P = S + α(G − S), the point its ray aims at (empty
    // for other rings).
    std::vector<glm::vec3> targets;
  };
  std::vector<ContourView> contours() const;

  // The stages separately (for benchmarks); evaluate() runs them in order.
  void stage_fk(const rig::Pose& pose);
  void stage_deform(const rig::Pose& pose);
  void stage_contours();
  void stage_bspline();
  void stage_stitch();

 private:
  struct Impl;
  explicit ImplicitSkin(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::avatar
