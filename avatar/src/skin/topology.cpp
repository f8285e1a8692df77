// The output mesh's vertices and triangles (fixed for a body and options): which control point
// or B-spline sample each vertex is, bands between rows, caps, rigid parts, part ranges.
#include "contour_layout_data.h"

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
    run.along = run.rows > 1 ? clamped_cubic_taps(run.rows, outs)
                             : std::vector<BsplineTap>{BsplineTap{{0, 0, 0, 0}, {1, 0, 0, 0}}};
    for (int i = 0; i < run.rows; ++i) s.out_row_of_control[r + static_cast<size_t>(i)] = out + i * sub;
    out += outs;
    s.runs.push_back(std::move(run));
    r = e;
  }
  return out;
}

using Data = ContourLayout::Data;

std::vector<uint32_t> index_range(uint32_t first, size_t n) {
  std::vector<uint32_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = first + static_cast<uint32_t>(i);
  return v;
}

uint32_t new_vertices(Data& d, size_t n) {
  const uint32_t first = d.vertex_count;
  d.vertex_count += static_cast<uint32_t>(n);
  return first;
}

// Subdivision 0: control points are the vertices, rows are the rings' slots.
void control_rows(Data& d) {
  new_vertices(d, d.control_points);
  for (Surface& s : d.surfaces) {
    s.out_rows.clear();
    s.out_row_of_control.clear();
    for (size_t r = 0; r < s.rows.size(); ++r) {
      s.out_rows.push_back(s.rows[r] < 0 ? s.first_row : d.rings[static_cast<size_t>(s.rows[r])].slots);
      s.out_row_of_control.push_back(static_cast<int>(r));
    }
  }
}

// Output rows of a surface, run by run (first_out → the row's columns); `first`, when given, is
// its row 0 (a limb's loop of torso and bridge vertices).
void add_out_rows(Data& d, Surface& s, const std::vector<uint32_t>* first) {
  const int sub = d.options.subdivision;
  s.out_rows.clear();
  plan_runs(s, d.rings, sub);
  for (const Surface::Run& run : s.runs) {
    const size_t c = s.control_row(d.rings, static_cast<size_t>(run.first_row)).size() * static_cast<size_t>(sub);
    for (size_t o = 0; o < run.along.size(); ++o)
      s.out_rows.push_back(first && s.out_rows.empty() ? *first : index_range(new_vertices(d, c), c));
  }
}

// The torso's points where its arcs meet, in output columns (see torso_angles in contour_layout.cpp).
struct Marks {
  int fl, kl, kr, fr, half, cols;
};
Marks output_marks(const Data& d) {
  const int sub = d.options.subdivision;
  const int m = static_cast<int>(d.rings[static_cast<size_t>(d.surfaces[0].rows[0])].slots.size());
  const int fl = d.counts.chest_front_arc / 2, kl = fl + d.counts.chest_side_arc;
  const int kr = kl + d.counts.chest_front_arc, fr = kr + d.counts.chest_side_arc;
  return {fl * sub, kl * sub, kr * sub, fr * sub, (m / 2) * sub, m * sub};
}

// Bridges hang between torso vertices: their ends on the torso's first (crotch) and last (chest)
// output rows, their interior samples new vertices.
void bridge_rows(Data& d, const Marks& k) {
  const int sub = d.options.subdivision;
  const std::vector<uint32_t>& bottom = d.surfaces[0].out_rows.front();
  const std::vector<uint32_t>& top = d.surfaces[0].out_rows.back();
  const std::pair<uint32_t, uint32_t> ends[3] = {
      {bottom[0], bottom[k.half]}, {top[k.fl], top[k.kl]}, {top[k.fr], top[k.kr]}};
  for (int b = 0; b < 3; ++b) {
    Bridge& br = d.bridges[b];
    const int segs = static_cast<int>(d.rings[br.ring].slots.size()) + 1;
    br.out_from = ends[b].first;
    br.out_to = ends[b].second;
    br.taps = clamped_cubic_taps(segs + 1, segs * sub + 1);
    br.out_interior = index_range(new_vertices(d, segs * sub - 1), segs * sub - 1);
  }
}

// The limbs' first rows from the torso's and bridges' output vertices, in the same orders as the
// control loops (contour_layout.cpp): neck (cut at the armpits), left and right arm, left and
// right leg.
std::vector<std::vector<uint32_t>> junction_loops(Data& d, const Marks& k) {
  const std::vector<uint32_t>& bottom = d.surfaces[0].out_rows.front();
  const std::vector<uint32_t>& top = d.surfaces[0].out_rows.back();
  auto bridge_out = [&](int b, bool reversed) {
    std::vector<uint32_t> v = d.bridges[b].out_interior;
    if (reversed) std::reverse(v.begin(), v.end());
    return v;
  };
  auto append = [](std::vector<uint32_t>& to, const std::vector<uint32_t>& v) {
    to.insert(to.end(), v.begin(), v.end());
  };
  auto top_range = [&](int from, int to) {  // inclusive, increasing, wrapping
    std::vector<uint32_t> v;
    for (int j = from;; j = (j + 1) % k.cols) {
      v.push_back(top[j]);
      if (j == to) break;
    }
    return v;
  };
  std::vector<std::vector<uint32_t>> loops(5);
  std::vector<uint32_t> nl;
  append(nl, top_range(0, k.fl));
  append(nl, bridge_out(1, false));
  append(nl, top_range(k.kl, k.kr));
  append(nl, bridge_out(2, true));
  append(nl, top_range(k.fr, k.cols - 1));
  cut_neck_loop(nl, d.neck_cuts, d.options.subdivision, loops[0], d.corners);
  append(loops[1], top_range(k.fl, k.kl));
  append(loops[1], bridge_out(1, true));
  loops[2].push_back(top[k.fr]);
  append(loops[2], bridge_out(2, false));
  append(loops[2], top_range(k.kr, k.fr - 1));
  loops[3].push_back(bottom[0]);
  append(loops[3], bridge_out(0, false));
  for (int j = k.half; j >= 1; --j) loops[3].push_back(bottom[j]);
  loops[4].push_back(bottom[0]);
  for (int j = k.cols - 1; j >= k.half; --j) loops[4].push_back(bottom[j]);
  append(loops[4], bridge_out(0, true));
  return loops;
}

// Subdivision n ≥ 1: torso first (its first and last output rows carry the loops), then
// bridges, then limbs.
void smoothed_rows(Data& d) {
  add_out_rows(d, d.surfaces[0], nullptr);
  const Marks k = output_marks(d);
  bridge_rows(d, k);
  const std::vector<std::vector<uint32_t>> loops = junction_loops(d, k);
  for (size_t si = 1; si < d.surfaces.size(); ++si) add_out_rows(d, d.surfaces[si], &loops[si - 1]);
  size_t cells = 0;
  for (const Surface& s : d.surfaces)
    for (const Surface::Run& run : s.runs)
      cells = std::max(cells, s.control_row(d.rings, static_cast<size_t>(run.first_row)).size() *
                                  static_cast<size_t>(run.rows * d.options.subdivision));
  d.bspline_cells = cells;
}

class Triangles {
 public:
  explicit Triangles(Data& d) : d_(d) {}
  void begin_part(const std::string& name) {
    MeshPart p;
    p.name = name;
    p.first_triangle = static_cast<uint32_t>(d_.indices.size() / 3);
    d_.parts.push_back(p);
  }
  void end_part() {
    MeshPart& p = d_.parts.back();
    p.triangle_count = static_cast<uint32_t>(d_.indices.size() / 3) - p.first_triangle;
  }
  void add(uint32_t a, uint32_t b, uint32_t c) { d_.indices.insert(d_.indices.end(), {a, b, c}); }
  void band(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) { append_band(d_.indices, a, b); }

 private:
  Data& d_;
};

// The skin pieces in the paper's order: torso pieces, neck, arms, legs.
void surface_triangles(Data& d, Triangles& tri) {
  for (Surface& s : d.surfaces) {
    for (size_t p = 0; p < s.parts.size(); ++p) {
      const int row_from = s.out_row_of_control[s.parts[p].second];
      const int row_to = p + 1 < s.parts.size() ? s.out_row_of_control[s.parts[p + 1].second]
                                                : static_cast<int>(s.out_rows.size()) - 1;
      tri.begin_part(s.parts[p].first);
      // The armpit corners the neck's loop cuts, ahead of the neck's bands.
      if (&s == &d.surfaces[1] && p == 0)
        for (const Corner& c : d.corners)
          c.for_each_triangle([&](size_t a, size_t b, size_t e) { tri.add(c.points[a], c.points[b], c.points[e]); });
      for (int r = row_from; r < row_to; ++r) tri.band(s.out_rows[r], s.out_rows[r + 1]);
      if (s.cap && p + 1 == s.parts.size()) {
        const auto& last = s.out_rows.back();
        for (size_t j = 0; j < last.size(); ++j) tri.add(last[j], last[(j + 1) % last.size()], s.cap_vertex);
      }
      tri.end_part();
    }
  }
}

// Head, hands, feet: each its own closed mesh (contour_layout.cpp add_rigid_part).
void rigid_triangles(const Data& d, Triangles& tri) {
  for (const RigidMesh& rm : d.rigid) {
    tri.begin_part(rigid_part_name(rm.part));
    for (size_t k = 0; k + 2 < rm.triangles.size(); k += 3)
      tri.add(rm.first_vertex + rm.triangles[k], rm.first_vertex + rm.triangles[k + 1],
              rm.first_vertex + rm.triangles[k + 2]);
    tri.end_part();
  }
}

}  // namespace

void build_topology(ContourLayout::Data& d) {
  d.vertex_count = 0;
  if (d.options.subdivision == 0)
    control_rows(d);
  else
    smoothed_rows(d);
  for (Surface& s : d.surfaces)
    if (s.cap) s.cap_vertex = new_vertices(d, 1);
  for (RigidMesh& rm : d.rigid) rm.first_vertex = new_vertices(d, rm.local.size());
  d.indices.clear();
  d.parts.clear();
  Triangles tri(d);
  surface_triangles(d, tri);
  rigid_triangles(d, tri);
}

}  // namespace mimic::avatar
