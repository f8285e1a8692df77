// The skin's contour layout: the build step between the authored body and the skins that run.
//
//   authored   BodyModel — primitives, skeleton, and SkinLayout (counts: rings per link, points
//              per ring, bridge segments; body_model.h)
//   built      ContourLayout::build(model, skeleton) — this type, immutable
//   runtime    ImplicitSkin (skin.h) ray-casts the layout's contours on the metaball surface every
//              frame; RealtimeBody (realtime_skin.h) measures them once and moves them; the
//              contour skin weights (skin_weights.h) and the texture layout (texture_layout.h)
//              read the same layout.
//
// What a layout holds, built once in the zero posture (a T-pose):
//   chains     polylines of skeleton points the contour planes sit on: the torso (crotch point
//              0.085 m below the pelvis up to the chest ring), the neck, each arm and each leg;
//              each node a joint and an offset in that joint's frame (metres)
//   rings      the contours: star rings (rays from a point on a chain, in the plane across it,
//              at fixed angles from the plane's front), boundary-driven rings (P = S + α(G − S)
//              between a limb's first star ring S and its loop G on the torso) and bridges (half
//              circles under the crotch and over the shoulders); each ring owns a contiguous
//              run of control points, indexed 0 … control_point_count() − 1
//   surfaces   the torso and the five limbs as rows of rings, the parts they make, the loops
//              where limbs meet the torso and the neck's armpit corners
//   rigid      the head, hands and feet sampled on the surface once, in their joint's frame
//   topology   the output mesh's vertex count, triangles and part ranges for the subdivision
//              (0: control points are the vertices; n ≥ 1: n cubic B-spline samples per span)
//
// A pose is never stored: planes and points are computed from a Pose by whoever runs the layout.
// Frames: world metres, +Y up, the body faces +Z, as the skeleton's forward kinematics gives them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

struct ContourLayoutOptions {
  int subdivision = 1;      // 0 … 16: B-spline samples per control span (0: none)
  bool rigid_parts = true;  // head, hands, feet
};

// One star ring's plane in a pose (world frame): where its rays start, the plane's unit normal
// (along the chain) and the rays' unit directions, in the ring's point order.
struct ContourPlane {
  std::string name;
  glm::vec3 origin_m{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
  std::vector<glm::vec3> directions;
};

class ContourLayout {
 public:
  // Fails on a model that does not validate, a skeleton without the joints the skin needs
  // (pelvis, spine, neck, head, shoulders/elbows/wrists, hips/knees/ankles) or a subdivision out
  // of range. Ray-casts the torso and bridges once in the zero posture (the limbs' ray angles face
  // their loops) and samples the rigid parts. Allocates; cheap to copy afterwards (shared).
  static Result<ContourLayout> build(const BodyModel& model, const rig::Skeleton& skeleton,
                                     const ContourLayoutOptions& options = {});

  const rig::Skeleton& skeleton() const;
  const ContourLayoutOptions& options() const;
  size_t ring_count() const;
  size_t control_point_count() const;
  size_t vertex_count() const;
  // The output mesh's triangles (3 indices each, wound outward) and its parts in order: the
  // eleven skin pieces, then head, hands and feet.
  std::span<const uint32_t> indices() const;
  std::span<const MeshPart> parts() const;
  // The star rings' planes in `pose` (it must have the skeleton's DOFs), in ring order.
  std::vector<ContourPlane> star_planes(const rig::Pose& pose) const;

  // The layout's tables, for the skin's own sources (avatar/src/skin/contour_layout_data.h).
  struct Data;
  const Data& data() const { return *data_; }

 private:
  explicit ContourLayout(std::shared_ptr<const Data> data);
  std::shared_ptr<const Data> data_;
};

}  // namespace mimic::avatar
