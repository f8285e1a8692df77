// Fitting the metaball body to a person's surface mesh (a scan, a MakeHuman export): the body's
// skeleton to the person's joints first, then its primitives' shapes to the surface, by
// optimisation against the surface distance `mimic compare` reports (surface_distance.h).
//
//   1. skeleton  the spine, neck and head links scaled to the reference's pelvis, neck, head and
//                head top heights; hips and shoulders moved onto the reference's; upper arm,
//                forearm, thigh and shin given the reference's lengths. Each primitive follows
//                its link: the part of its centre along the link and its semi-axis along the
//                link scale with the link's length.
//   2. shapes    Levenberg–Marquardt over every metaball's centre (joint frame) and the logarithm
//                of its three semi-axes (hard ellipsoids, orientations, weights and radii of
//                influence are kept; a muscle's deformed states move and scale with its relaxed
//                one). The residuals are point-to-plane distances both ways between the skin
//                mesh (the body posed like the reference, at the LOD measured) and the reference:
//                area-weighted samples of each surface against the other, robustly weighted
//                (Huber). How a residual changes with a primitive comes from the body field at
//                the nearest contour point (or rigid-part vertex): the surface moves along its
//                normal by (∂F/∂θ) / |∇F|, F summed over that contour's group (or the rigid
//                part). A step is kept only when the measured mean distance both ways drops and
//                the skin stays a closed, oriented manifold without new folds. Optionally the
//                tape girths too (FitOptions::girth_weight).
//
// Metres, +Y up, the reference faces +Z (the skin is posed like it with pose_to_match).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/measure.h"
#include "mimic/avatar/mesh.h"
#include "mimic/avatar/surface_distance.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

// The body skinned in the reference's posture, as `mimic compare` measures it.
struct PosedBody {
  Mesh mesh;
  BodyLandmarks landmarks;
  rig::Pose pose;
  int folds = 0;                       // adjacent triangles (≥ 10 mm² each) whose normals turn > 150°
  std::vector<int> part_folds;         // the same per mesh part (mesh.parts order)
  std::vector<glm::vec3> fold_points;  // each fold's shared edge's midpoint
  bool closed = false;                 // a closed, oriented manifold
  int missed_rays = 0;                 // contour rays that found no surface
};
Result<PosedBody> pose_body_like(const BodyModel& model, const BodyLandmarks& reference, int subdivision = 2);

// Folds of a mesh: pairs of edge-adjacent triangles, each of at least `min_area_m2`, whose
// normals turn by more than 150°. With `per_part`, also the count per mesh part (a fold counts
// in the part of the pair's second triangle).
// With `where`, each fold's shared edge's midpoint.
int count_folds(const Mesh& mesh, float min_area_m2 = 1e-5f, std::vector<int>* per_part = nullptr,
                std::vector<glm::vec3>* where = nullptr);

// Step 1 alone: the body with its skeleton fitted to the landmarks (primitives following; the
// rigid parts' primitives too unless `hold_rigid`, when they keep their shapes in their joints'
// frames).
Result<BodyModel> fit_skeleton(const BodyModel& model, const BodyLandmarks& reference, bool hold_rigid = false);

struct FitProgress {
  std::string stage;  // "start", "skeleton", "shapes"
  int iteration = 0, iterations = 0;
  SurfaceDistance distance;
  bool accepted = true;
  float largest_girth_error = 0;  // relative, of the girths fitted (0 when none are)
};

struct FitOptions {
  int iterations = 30;   // shape iterations (each one skin and one measurement, or a few when
                         // a step is refused)
  int samples = 8000;    // area-weighted samples per surface, per iteration
  int subdivision = 2;   // skin LOD measured (compare's)
  bool skeleton = true;  // step 1
  bool shapes = true;    // step 2
  // The rigid parts' primitives (head, hands, feet) kept as they are, in their joints' frames:
  // the built-in body's refit, whose rigid parts are authored in code (body_overrides.h).
  bool hold_rigid = false;
  // The rigid parts' primitives change shape in step 2 too (each phalanx, an ear). Off, they keep
  // their modelled shapes and follow their links in step 1 only (unless hold_rigid): a scan's
  // fingers and ears are rarely where a hand's or head's model can follow them, and the shipped
  // meshes then carry onto them, where re-meshing every part costs a second a step.
  bool fit_rigid_shapes = false;
  // Primitives whose shapes stay as they are (names; "l_NAME" holds "r_NAME" too): the built-in
  // body's refit holds those of the neck and shoulder girdle, whose fitted shapes made the neck's
  // first rings zigzag (docs/fit.md).
  std::vector<std::string> held;
  // The reference's tape girths as residuals beside the surface's: chest, waist, hips and each
  // side's thigh, calf and upper arm, taken as `mimic compare` takes them (measure_body). A girth
  // further than `girth_band` (relative) from the reference's counts with the radius by which it
  // exceeds the band, as `girth_weight` of one side's samples would (in the step and in the
  // score a step must lower): 0.05 of 22,000 samples is 1,100 samples' worth. The surface
  // distance alone leaves girths a few per cent off where a slice's tape bridges what the mean
  // distance hardly sees (docs/fit.md). 0: the surface alone.
  float girth_weight = 0.05f;
  float girth_band = 0.01f;
  // Each right primitive moved as its left twin's mirror image (in x, in the joints' frames),
  // the body made symmetric (`symmetrised`) before the shapes: what is fitted is what a
  // symmetric body (the built-in one) writes, instead of the mean of two sides fitted apart.
  bool symmetric = false;
  std::function<void(const FitProgress&)> progress;
};

struct FitResult {
  BodyModel body;
  SurfaceDistance before, after;  // measured with FitOptions::samples per side
  int iterations = 0, accepted = 0;
  int folds_before = 0, folds_after = 0;
};

// Fails with invalid_argument on an empty reference or a body that does not skin.
Result<FitResult> fit_body(const BodyModel& start, const Mesh& reference_m, const BodyLandmarks& reference_landmarks,
                           const FitOptions& options = {});

}  // namespace mimic::avatar
