// The paper's realtime skin (§4.1): contours are ray-cast once, in an initial pose; afterwards a
// frame only moves each contour point with the configuration of its ring. No ray, no field
// evaluation, no B-spline per frame:
//
//   star rings      on the ring's plane of the current pose (joint-angle driven: bisector
//                   normals at the joints, interpolated along links); a limb point keeps its
//                   place across the link and, as the plane tilts, slides along its column of
//                   the rest surface (through the same point of the neighbouring rings of its
//                   link) to where the column meets the plane, so the limb keeps its shape
//                   along the bone and the two links meet as a mitre
//   joint bands     near an elbow or knee the rings are scaled about their rest centroid by a
//                   function of the bend, measured at build time so the joint zone keeps its
//                   volume
//   the crease      where a bend tilts a ring's plane through its neighbour's, the points of
//                   both stop on the line the planes share: adjacent contours never cross
//   driven rings    p = S + α(G − S) + residual, S and G the moved start ring and loop
//   bridges         p = o + x·(half chord)·front + y·up + z·side, from their moved end points
//   caps, rigid     the ring's centroid; head, hands and feet moved rigidly with their joint
//
// Each point's coordinates are measured in the initial pose, so that pose comes out exactly as
// the full method (ImplicitSkin, subdivision 0) draws it, vertex for vertex.
//
// Muscles, beyond the paper: for every DOF that deforms a primitive (the biceps' elbow flexion,
// the calf's knee flexion…), the contours are also ray-cast in the initial posture with that
// DOF's primitives shaped as at θ0, θmin and θmax; at run time each star ring point's
// coordinates move by the same f(t) as the primitive (t = (θ − θ0)/(θmax − θ0), or towards
// θmin), so the biceps still bulges without a ray.
//
// Sharing: RealtimeBody is immutable and built once per body, skeleton and LOD (the contour
// coordinates, the muscle table, the mesh topology, the skinning weights, the texture layout);
// every avatar with that body holds a shared_ptr to it (RealtimeBody::shared finds it) and a
// RealtimeSkin of a few kilobytes (joint transforms, chain nodes, ring frames), plus its own
// vertex buffer. docs/skin.md has the figures.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/contour_layout.h"
#include "mimic/avatar/mesh.h"
#include "mimic/avatar/mesh_check.h"
#include "mimic/rig/skeleton.h"
#include "mimic/avatar/skin_weights.h"
#include "mimic/avatar/texture_layout.h"

namespace mimic::avatar {

// How a skin is made each frame: `full` ray-casts every contour (ImplicitSkin), `realtime` moves the
// contours measured once (RealtimeSkin).
enum class SkinMethod : uint8_t { full, realtime };
const char* skin_method_name(SkinMethod m);
Result<SkinMethod> parse_skin_method(std::string_view name);  // "full" or "realtime"

struct RealtimeOptions {
  int lod = 0;                            // skin_lod.h: 0 finest … kSkinLodCount − 1 coarsest
  std::optional<rig::Pose> initial_pose;  // where the contours are ray-cast; default the zero posture
  bool rigid_parts = true;                // head, hands, feet
  // Contact (docs/skin.md, "Contact"): the tables that let a frame push one piece's skin out of
  // another's volume (arm against chest, calf against calf) and turn an arm whose hand or forearm
  // passes into the torso or a thigh off the body. Off: none are built, and no frame can apply them.
  bool contact = true;
};

class RealtimeBody {
 public:
  // Ray-casts the contours once (initial pose, and θ0/θmin/θmax of every muscle DOF). Allocates.
  static Result<std::shared_ptr<const RealtimeBody>> create(const BodyModel& model, const rig::Skeleton& skeleton,
                                                            const RealtimeOptions& options = {});
  static Result<std::shared_ptr<const RealtimeBody>> create(const BodyModel& model,
                                                            const RealtimeOptions& options = {});
  // From a layout already built (subdivision 0; contour_layout.h) of this model: the layout fixes
  // the LOD's counts and the rigid parts, options.lod is what lod() reports, options.initial_pose
  // where the contours are ray-cast. The rest mesh has the layout's vertices and triangles.
  static Result<std::shared_ptr<const RealtimeBody>> create(const BodyModel& model, const ContourLayout& layout,
                                                            const RealtimeOptions& options = {});
  // The same, but a body already built for an equal model, skeleton and options and still held
  // by some avatar is returned instead of a new one (thread-safe): avatars of one body share it.
  static Result<std::shared_ptr<const RealtimeBody>> shared(const BodyModel& model, const rig::Skeleton& skeleton,
                                                            const RealtimeOptions& options = {});

  const rig::Skeleton& skeleton() const;
  // Topology (indices, parts) and the positions of the initial pose; shared by every avatar.
  const Mesh& rest_mesh() const;
  // contour_skin_weights() of the rest mesh, one per vertex.
  std::span<const JointInfluences> weights() const;
  int lod() const;
  // Per-part texture coordinates of the rest mesh (textured_mesh() splits a frame's seams).
  const TextureLayout& texture_layout() const;
  // The planar contours (star rings) of each surface (torso, neck, arms, legs) in order, as
  // vertex indices, for check_contour_order (mesh_check.h).
  std::span<const ContourRows> contour_rows() const;
  size_t vertex_count() const { return rest_mesh().positions.size(); }
  // Points moved by muscle terms, and the terms (a point can follow several DOFs).
  size_t muscle_points() const;
  size_t muscle_terms() const;
  // Contour rays of the initial pose that found no surface (a skeleton other than the model's
  // can leave gaps); their points are placed as the full method places them.
  int missed_rays() const;
  // Contact: the part pairs one of which gives way to the other, and the vertices they list
  // (a vertex can be in several pairs).
  size_t contact_pairs() const;
  size_t contact_vertices() const;
  // Heap bytes of this shared body (the cost of the first avatar, paid once).
  size_t shared_bytes() const;
  // What one frame's points cost, counted from the tables (docs/skin.md, "Speed, and what
  // bounds it"): bytes the point loops read and write, and floating-point operations (a fused
  // multiply-add counts two), for the contour points, muscle terms, boundary-driven rings,
  // bridges, caps and rigid parts; the ring frames and joints are left out (a few kilobytes).
  struct FrameWork {
    double bytes_read = 0, bytes_written = 0, flops = 0;
  };
  FrameWork work_per_frame(bool muscles = true) const;

  struct Data;
  const Data& data() const { return *data_; }
  explicit RealtimeBody(std::unique_ptr<Data> data);
  ~RealtimeBody();

 private:
  std::unique_ptr<Data> data_;
};

struct RealtimeTimings {
  double joints_us = 0;  // forward kinematics, chain nodes, ring frames, muscle weights
  double points_us = 0;  // contour points, caps, rigid parts
  double normals_us = 0;
  double contact_us = 0;  // pushing one piece out of another (RealtimeSkin::evaluate's `contact`)
  double total_us() const { return joints_us + points_us + normals_us + contact_us; }
};

class RealtimeSkin {
 public:
  explicit RealtimeSkin(std::shared_ptr<const RealtimeBody> body);
  RealtimeSkin(RealtimeSkin&&) noexcept;
  RealtimeSkin& operator=(RealtimeSkin&&) noexcept;
  ~RealtimeSkin();

  // Writes body().vertex_count() positions (and, when `normals_out` is not empty, area-weighted
  // unit normals) for the pose. With `muscles` false, the contours keep their initial shape
  // (the paper's method alone). With `contact` (and a body built with it), an arm whose hand or
  // forearm passes into the torso or a thigh turns about its shoulder onto that surface (a rigid
  // hand cannot flatten), and a piece's vertices that pass into another piece's volume are pushed
  // out onto its surface (docs/skin.md, "Contact"); off, the frame is the same as without the
  // tables. Never allocates, never throws.
  void evaluate(const rig::Pose& pose, std::span<glm::vec3> positions_out, std::span<glm::vec3> normals_out = {},
                bool muscles = true, bool contact = true);

  // The contour points are moved eight at a time where the build targets AVX2 and FMA (as the
  // baseline skinnings are); `scalar` true takes the scalar reference loop instead, which the
  // tests hold the vectorised one to.
  void use_scalar_reference(bool scalar);
  static bool vectorised_kernel();

  const RealtimeBody& body() const { return *body_; }
  const RealtimeTimings& timings() const;
  // Vertices the last frame's contact pushed out of another piece.
  size_t contact_moved() const;
  // Heap bytes this avatar holds beyond the shared body and its vertex buffer.
  size_t instance_bytes() const;

 private:
  std::shared_ptr<const RealtimeBody> body_;
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mimic::avatar
