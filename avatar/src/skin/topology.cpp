// The output mesh's vertices and triangles (fixed for a body and options): which control point
// or B-spline sample each vertex is, bands between rows, caps, rigid parts, part ranges.
#include "skin_impl.h"

namespace mimic::avatar {

// ---------------------------------------------------------------------------------------------
// Output topology

namespace {

void append_band(std::vector<uint32_t>& idx, const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  const size_t n = a.size();
  for (size_t j = 0; j < n; ++j) {
    const size_t j1 = (j + 1) % n;
    idx.insert(idx.end(), {a[j], a[j1], b[j1]});
    idx.insert(idx.end(), {a[j], b[j1], b[j]});
  }
}

}  // namespace

void BodySkin::Impl::build_output() {
  const int sub = options.subdivision;
  std::vector<glm::vec3>& pos = mesh.positions;
  pos.clear();
  auto new_vertices = [&](size_t n) {
    const uint32_t first = static_cast<uint32_t>(pos.size());
    pos.resize(pos.size() + n);
    return first;
  };
  auto range = [](uint32_t first, size_t n) {
    std::vector<uint32_t> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = first + static_cast<uint32_t>(i);
    return v;
  };

  if (sub == 0) {
    // Realtime mode: control points are the vertices.
    new_vertices(ctrl.size());
    for (Surface& s : surfaces) {
      s.out_rows.clear();
      s.out_row_of_control.clear();
      for (size_t r = 0; r < s.rows.size(); ++r) {
        s.out_rows.push_back(s.rows[r] < 0 ? s.first_row : rings[s.rows[r]].slots);
        s.out_row_of_control.push_back(static_cast<int>(r));
      }
    }
  } else {
    // Torso first (its first and last output rows carry the loops), then bridges, then limbs.
    Surface& torso = surfaces[0];
    const int m = static_cast<int>(rings[torso.rows[0]].slots.size());
    const int cols = m * sub;
    const int out_n = (static_cast<int>(torso.rows.size()) - 1) * sub + 1;
    torso.around = periodic_cubic_taps(m, sub);
    torso.along = clamped_cubic_taps(static_cast<int>(torso.rows.size()), out_n);
    for (int o = 0; o < out_n; ++o) torso.out_rows.push_back(range(new_vertices(cols), cols));
    for (size_t r = 0; r < torso.rows.size(); ++r) torso.out_row_of_control.push_back(static_cast<int>(r) * sub);
    const std::vector<uint32_t>& bottom = torso.out_rows.front();
    const std::vector<uint32_t>& top = torso.out_rows.back();
    const int half = m / 2;
    const int f_half = layout.chest_front_arc / 2;
    const int fl = f_half, kl = f_half + layout.chest_side_arc;
    const int kr = kl + layout.chest_front_arc, fr = kr + layout.chest_side_arc;
    const std::pair<uint32_t, uint32_t> ends[3] = {{bottom[0], bottom[half * sub]},
                                                   {top[fl * sub], top[kl * sub]},
                                                   {top[fr * sub], top[kr * sub]}};
    for (int b = 0; b < 3; ++b) {
      Bridge& br = bridges[b];
      const int segs = static_cast<int>(rings[br.ring].slots.size()) + 1;
      br.out_from = ends[b].first;
      br.out_to = ends[b].second;
      br.taps = clamped_cubic_taps(segs + 1, segs * sub + 1);
      br.out_interior = range(new_vertices(segs * sub - 1), segs * sub - 1);
    }
    auto bridge_out = [&](int b, bool reversed) {
      std::vector<uint32_t> v = bridges[b].out_interior;
      if (reversed) std::reverse(v.begin(), v.end());
      return v;
    };
    auto top_range = [&](int from, int to) {  // inclusive, increasing, wrapping
      std::vector<uint32_t> v;
      for (int j = from;; j = (j + 1) % cols) {
        v.push_back(top[j]);
        if (j == to) break;
      }
      return v;
    };
    std::vector<std::vector<uint32_t>> loops(5);
    {
      // Same orders as the control loops (see build()).
      auto& nl = loops[0];
      auto a = top_range(0, fl * sub);
      nl.insert(nl.end(), a.begin(), a.end());
      auto lb = bridge_out(1, false);
      nl.insert(nl.end(), lb.begin(), lb.end());
      a = top_range(kl * sub, kr * sub);
      nl.insert(nl.end(), a.begin(), a.end());
      auto rb = bridge_out(2, true);
      nl.insert(nl.end(), rb.begin(), rb.end());
      a = top_range(fr * sub, cols - 1);
      nl.insert(nl.end(), a.begin(), a.end());

      auto& la = loops[1];
      a = top_range(fl * sub, kl * sub);
      la.insert(la.end(), a.begin(), a.end());
      lb = bridge_out(1, true);
      la.insert(la.end(), lb.begin(), lb.end());

      auto& ra = loops[2];
      ra.push_back(top[fr * sub]);
      rb = bridge_out(2, false);
      ra.insert(ra.end(), rb.begin(), rb.end());
      a = top_range(kr * sub, fr * sub - 1);
      ra.insert(ra.end(), a.begin(), a.end());

      auto& ll = loops[3];
      ll.push_back(bottom[0]);
      auto cb = bridge_out(0, false);
      ll.insert(ll.end(), cb.begin(), cb.end());
      for (int j = half * sub; j >= 1; --j) ll.push_back(bottom[j]);

      auto& rl = loops[4];
      rl.push_back(bottom[0]);
      for (int j = cols - 1; j >= half * sub; --j) rl.push_back(bottom[j]);
      cb = bridge_out(0, true);
      rl.insert(rl.end(), cb.begin(), cb.end());
    }
    for (size_t si = 1; si < surfaces.size(); ++si) {
      Surface& s = surfaces[si];
      const int n = static_cast<int>(s.first_row.size());
      const int c = n * sub;
      const int rows_out = (static_cast<int>(s.rows.size()) - 1) * sub + 1;
      s.around = periodic_cubic_taps(n, sub);
      s.along = clamped_cubic_taps(static_cast<int>(s.rows.size()), rows_out);
      s.out_rows.push_back(loops[si - 1]);
      for (int o = 1; o < rows_out; ++o) s.out_rows.push_back(range(new_vertices(c), c));
      for (size_t r = 0; r < s.rows.size(); ++r) s.out_row_of_control.push_back(static_cast<int>(r) * sub);
    }
    size_t cells = 0;
    for (const Surface& s : surfaces) {
      const size_t n = s.rows[0] < 0 ? s.first_row.size() : rings[s.rows[0]].slots.size();
      cells = std::max(cells, n * s.rows.size() * sub);
    }
    scratch_rows.resize(cells);
    scratch_grid.resize(cells);
    scratch_poly.resize(1024);
  }
  for (Surface& s : surfaces)
    if (s.cap) s.cap_vertex = new_vertices(1);
  for (RigidMesh& rm : rigid) rm.first_vertex = new_vertices(rm.local.size());

  // Triangles, part by part.
  mesh.indices.clear();
  mesh.parts.clear();
  auto begin_part = [&](const std::string& name) {
    MeshPart p;
    p.name = name;
    p.first_triangle = static_cast<uint32_t>(mesh.indices.size() / 3);
    mesh.parts.push_back(p);
  };
  auto end_part = [&]() {
    MeshPart& p = mesh.parts.back();
    p.triangle_count = static_cast<uint32_t>(mesh.indices.size() / 3) - p.first_triangle;
  };
  // Parts in the paper's order: torso pieces, neck, arms, legs, then rigid parts.
  for (Surface& s : surfaces) {
    for (size_t p = 0; p < s.parts.size(); ++p) {
      const int row_from = s.out_row_of_control[s.parts[p].second];
      const int row_to = p + 1 < s.parts.size() ? s.out_row_of_control[s.parts[p + 1].second]
                                                : static_cast<int>(s.out_rows.size()) - 1;
      begin_part(s.parts[p].first);
      for (int r = row_from; r < row_to; ++r) append_band(mesh.indices, s.out_rows[r], s.out_rows[r + 1]);
      if (s.cap && p + 1 == s.parts.size()) {
        const auto& last = s.out_rows.back();
        for (size_t j = 0; j < last.size(); ++j)
          mesh.indices.insert(mesh.indices.end(), {last[j], last[(j + 1) % last.size()], s.cap_vertex});
      }
      end_part();
    }
  }
  for (const RigidMesh& rm : rigid) {
    begin_part(rigid_part_name(rm.part));
    const uint32_t south = rm.first_vertex;
    const uint32_t rings_n = static_cast<uint32_t>(layout.rigid_rings), pts = static_cast<uint32_t>(layout.rigid_points);
    const uint32_t north = south + 1 + rings_n * pts;
    auto ring = [&](uint32_t r) {
      std::vector<uint32_t> v(pts);
      for (uint32_t j = 0; j < pts; ++j) v[j] = south + 1 + r * pts + j;
      return v;
    };
    const auto first = ring(0);
    for (uint32_t j = 0; j < pts; ++j) mesh.indices.insert(mesh.indices.end(), {first[(j + 1) % pts], first[j], south});
    for (uint32_t r = 0; r + 1 < rings_n; ++r) append_band(mesh.indices, ring(r), ring(r + 1));
    const auto last = ring(rings_n - 1);
    for (uint32_t j = 0; j < pts; ++j) mesh.indices.insert(mesh.indices.end(), {last[j], last[(j + 1) % pts], north});
    end_part();
  }
  if (options.normals) {
    mesh.normals.assign(pos.size(), glm::vec3(0, 1, 0));
    normal_sums.assign(pos.size(), glm::vec4(0));
  }
}

}  // namespace mimic::avatar
