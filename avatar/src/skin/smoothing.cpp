// Per frame after the contours: cubic B-spline smoothing of the control rows (or a copy in the
// realtime resolution) and area-weighted vertex normals.
#include "mimic/core/vertex_normals.h"
#include "skin_impl.h"

namespace mimic::avatar {

// ---------------------------------------------------------------------------------------------
// Per frame

void ImplicitSkin::Impl::evaluate_bspline() {
  std::vector<glm::vec3>& pos = mesh.positions;
  const std::vector<glm::vec3>& ctrl = caster.ctrl;
  if (L.options.subdivision == 0) {
    std::copy(ctrl.begin(), ctrl.end(), pos.begin());
    return;
  }
  const size_t sub = static_cast<size_t>(L.options.subdivision);
  const std::vector<Ring>& rings = L.rings;
  for (size_t si = 0; si < L.surfaces.size(); ++si) {
    const Surface& s = L.surfaces[si];
    for (const Surface::Run& run : s.runs) {
      const size_t first = static_cast<size_t>(run.first_row), rows = static_cast<size_t>(run.rows);
      const size_t cols = s.control_row(rings, first).size() * sub;
      // Around: each control row → cols samples (closed curve).
      for (size_t r = 0; r < rows; ++r) {
        const std::vector<uint32_t>& slots = s.control_row(rings, first + r);
        glm::vec3* dst = &scratch_rows[r * cols];
        for (size_t c = 0; c < cols; ++c) {
          const BsplineTap& t = run.around[c];
          dst[c] = t.weight[0] * ctrl[slots[t.index[0]]] + t.weight[1] * ctrl[slots[t.index[1]]] +
                   t.weight[2] * ctrl[slots[t.index[2]]] + t.weight[3] * ctrl[slots[t.index[3]]];
        }
      }
      // Along: clamped within the run; limbs keep their first row from the torso/bridges
      // (shared vertices).
      for (size_t o = 0; o < run.along.size(); ++o) {
        const size_t out_row = static_cast<size_t>(run.first_out) + o;
        if (s.loop_start && out_row == 0) continue;
        const BsplineTap& t = run.along[o];
        const glm::vec3* r0 = &scratch_rows[t.index[0] * cols];
        const glm::vec3* r1 = &scratch_rows[t.index[1] * cols];
        const glm::vec3* r2 = &scratch_rows[t.index[2] * cols];
        const glm::vec3* r3 = &scratch_rows[t.index[3] * cols];
        const std::vector<uint32_t>& out = s.out_rows[out_row];
        for (size_t c = 0; c < cols; ++c)
          pos[out[c]] = t.weight[0] * r0[c] + t.weight[1] * r1[c] + t.weight[2] * r2[c] + t.weight[3] * r3[c];
      }
    }
    if (si == 0) {
      // Bridges hang between torso vertices: polygon [end, interior…, end], clamped.
      for (const Bridge& b : L.bridges) {
        const std::vector<uint32_t>& interior = rings[b.ring].slots;
        const size_t np = interior.size() + 2;
        scratch_poly[0] = pos[b.out_from];
        for (size_t i = 0; i < interior.size(); ++i) scratch_poly[i + 1] = ctrl[interior[i]];
        scratch_poly[np - 1] = pos[b.out_to];
        for (size_t i = 0; i < b.out_interior.size(); ++i)
          pos[b.out_interior[i]] = apply_tap(b.taps[i + 1], scratch_poly);
      }
    }
  }
}

void ImplicitSkin::Impl::update_normals() { vertex_normals(mesh.positions, mesh.indices, mesh.normals); }

}  // namespace mimic::avatar
