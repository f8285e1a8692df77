// The output mesh's vertices and triangles (fixed for a body and options): which control point
// or B-spline sample each vertex is, bands between rows, caps, rigid parts, part ranges.
#include "skin_impl.h"

namespace mimic::avatar {

// ---------------------------------------------------------------------------------------------
// Output topology

namespace {

void append_band(std::vector<uint32_t>& idx, const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  auto vertex = [&](BandCorner c) {
    const std::vector<uint32_t>& row = c.row ? b : a;
    return row[c.col % row.size()];
  };
  for_each_band_triangle(static_cast<uint32_t>(a.size()), static_cast<uint32_t>(b.size()),
                         [&](BandCorner c0, BandCorner c1, BandCorner c2) {
                           idx.insert(idx.end(), {vertex(c0), vertex(c1), vertex(c2)});
                         });
}

// Splits a surface's control rows into runs of one point count and plans their B-spline
// samples: `sub` per span around, clamped along (a run of one row is copied). Returns the
// number of output rows.
int plan_runs(Surface& s, const std::vector<Ring>& rings, int sub) {
  s.runs.clear();
  s.out_row_of_control.assign(s.rows.size(), 0);
  int out = 0;
  for (size_t r = 0; r < s.rows.size();) {
    const size_t n = s.control_row(rings, r).size();
    size_t e = r + 1;
    while (e < s.rows.size() && s.control_row(rings, e).size() == n) ++e;
    Surface::Run run;
    run.first_row = static_cast<int>(r);
    run.rows = static_cast<int>(e - r);
    run.first_out = out;
    const int outs = (run.rows - 1) * sub + 1;
    run.around = periodic_cubic_taps(static_cast<int>(n), sub);
    run.along = run.rows > 1 ? clamped_cubic_taps(run.rows, outs) : std::vector<BsplineTap>{BsplineTap{{0, 0, 0, 0}, {1, 0, 0, 0}}};
    for (int i = 0; i < run.rows; ++i) s.out_row_of_control[r + static_cast<size_t>(i)] = out + i * sub;
    out += outs;
    s.runs.push_back(std::move(run));
    r = e;
  }
  return out;
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
    // Output rows of each surface, run by run (first_out → the row's columns).
    auto add_out_rows = [&](Surface& s, const std::vector<uint32_t>* first) {
      s.out_rows.clear();
      plan_runs(s, rings, sub);
      for (const Surface::Run& run : s.runs) {
        const size_t c = s.control_row(rings, static_cast<size_t>(run.first_row)).size() * static_cast<size_t>(sub);
        for (size_t o = 0; o < run.along.size(); ++o)
          s.out_rows.push_back(first && s.out_rows.empty() ? *first : range(new_vertices(c), c));
      }
    };
    Surface& torso = surfaces[0];
    const int m = static_cast<int>(rings[torso.rows[0]].slots.size());
    const int cols = m * sub;
    add_out_rows(torso, nullptr);
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
      std::vector<uint32_t> nl;
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
      cut_neck_loop(nl, neck_cuts, sub, loops[0], corners);

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
    for (size_t si = 1; si < surfaces.size(); ++si) add_out_rows(surfaces[si], &loops[si - 1]);
    size_t cells = 0;
    for (const Surface& s : surfaces)
      for (const Surface::Run& run : s.runs)
        cells = std::max(cells, s.control_row(rings, static_cast<size_t>(run.first_row)).size() *
                                    static_cast<size_t>(run.rows * sub));
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
      // The armpit corners the neck's loop cuts, ahead of the neck's bands.
      if (&s == &surfaces[1] && p == 0)
        for (const Corner& c : corners)
          c.for_each_triangle([&](size_t a, size_t b, size_t d) {
            mesh.indices.insert(mesh.indices.end(), {c.points[a], c.points[b], c.points[d]});
          });
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
