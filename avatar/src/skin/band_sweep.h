// The shoulders' boundary-driven bands as a swept tube (realtime skin). Not a public header.
//
// A band joins the torso's loop G to the arm's first ring S. Blended point by point in space,
// P = S + α(G − S), its rings fold wherever the two ends do not face each other: with the arm
// hanging the loop faces sideways and S faces down, a right-angled bend whose inner side the
// straight columns cross, and with the arm twisted the blend of two turned shapes pinches where a
// column's two ends lie on opposite sides of the band's axis (the armpit, `mimic intersect`: 7.8
// of the 14 folds a frame of the shared clips at LOD 0).
//
// Swept instead: each ring lies in its own plane, centred on a cubic Hermite curve from G's
// centre (leaving along G's normal) to S's (arriving along S's), its plane across the curve, its
// axes carried along the curve without turning about it (parallel transport). In that plane a
// point is placed in polar form, each column's radius, height and angle blended from G's and
// S's: the angle so that the ring turns from G's shape to S's with the twist (the limb's turn
// about the band against the initial pose, one for the whole band, tapered as twist_in_band)
// given mostly near S (its share t^3, t from 0 at G to 1 at S). Every ring is then star-shaped
// in its plane wherever both ends are, and the planes turn one way along the curve. The
// initial pose's shape (the full method's points) is kept as polar offsets from that blend
// (radius, angle, height), shrunk with the column as the Cartesian offsets are.
#pragma once

#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "realtime_data.h"

namespace mimic::avatar::realtime_detail {

// atan2 within 1e-5 rad (a polynomial and quadrant selects; the sweep's scalar reference).
float approx_atan2(float y, float x);

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
