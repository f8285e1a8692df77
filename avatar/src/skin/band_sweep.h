// The shoulders' boundary-driven bands as a swept tube (realtime skin). Not a public header.
//
// A band joins the torso's loop G to the arm's first ring S. Blended point by point in space,
// P = S + α(G − S), its rings fold wherever the two ends do not face each other: with the arm
// hanging the loop faces sideways and S faces down, a right-angled bend whose inner side the
// straight columns cross, and with the arm twisted the blend of two turned shapes pinches where a
// column's two ends lie on opposite sides of the band's axis (the armpit, `mimic intersect`: 7.8
// of the 14 folds a frame of the shared clips at LOD 0).
//
// Swept instead (sweep_geometry.h): each ring in its own plane along a curve from G to S, each
// point blended in polar form, so that every ring is star-shaped where both ends are. The
// initial pose's shape (the full method's points) is kept as polar offsets from that blend
// (radius, angle, height), shrunk with the column as the Cartesian offsets are.
#pragma once

#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "realtime_data.h"

namespace mimic::avatar::realtime_detail {

// The limb's twist about its own axis against the initial pose (swing-twist), radians.
float limb_twist_rad(const RealtimeBody::Data::Sweep& b, std::span<const rig::RigidTransform> world_from_joint);
// Every ring of swept band `b` into scratch.points, one ring after another, from G and S as
// they are in `pos`, the limb twisted by `twist_rad` (limb_twist_rad). Never allocates.
// Eight points at a time where the build has AVX2 and FMA and `vectorised`.
void sweep_band(const RealtimeBody::Data& d, const RealtimeBody::Data::Sweep& b, float twist_rad,
                std::span<const glm::vec3> pos, SweepScratch& scratch, bool vectorised);

// Build time: the shoulders' bands become sweeps (`Data::sweeps`, RingOp::sweep) with the polar
// offsets (`Data::sweep_offset`) that give back `rest` (the initial pose's points, its joints
// `world_from_joint`) exactly. After the loop follows are measured.
void measure_sweeps(std::span<const glm::vec3> rest, std::span<const rig::RigidTransform> world_from_joint,
                    RealtimeBody::Data& d);

}  // namespace mimic::avatar::realtime_detail
