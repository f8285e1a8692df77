// Landmarks, body measurements and their comparison tables.
#include <algorithm>
#include <tuple>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "mimic/avatar/measure.h"
#include "mimic/core/file.h"

namespace mimic::avatar {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool parse_float(std::string_view s, float& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size() && std::isfinite(out);
}

// x, z of the torso axis at height y: the pelvis–spine–neck polyline, clamped at its ends.
glm::vec3 torso_axis_at(const BodyLandmarks& lm, float y) {
  std::vector<glm::vec3> chain{lm.pelvis_m};
  chain.insert(chain.end(), lm.spine_m.begin(), lm.spine_m.end());
  chain.push_back(lm.neck_m);
  if (y <= chain.front().y) return {chain.front().x, y, chain.front().z};
  for (size_t i = 0; i + 1 < chain.size(); ++i) {
    const glm::vec3 a = chain[i], b = chain[i + 1];
    if (y <= b.y && b.y > a.y) {
      const float t = (y - a.y) / (b.y - a.y);
      const glm::vec3 p = a + t * (b - a);
      return {p.x, y, p.z};
    }
  }
  return {chain.back().x, y, chain.back().z};
}

// The point of segment a→b at height y, if the segment spans y (not for level segments).
std::optional<glm::vec3> segment_at(const glm::vec3& a, const glm::vec3& b, float y, bool clamp = false) {
  if (std::abs(b.y - a.y) < 1e-6f) return std::nullopt;
  float t = (y - a.y) / (b.y - a.y);
  if (clamp)
    t = std::clamp(t, 0.0f, 1.0f);
  else if (t < 0 || t > 1)
    return std::nullopt;
  glm::vec3 p = a + t * (b - a);
  p.y = y;
  return p;
}

std::vector<float> levels(float from, float to) {
  const float step = 0.005f;
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(to - from) / step)));
  std::vector<float> out;
  for (int i = 0; i <= n; ++i) out.push_back(from + (to - from) * static_cast<float>(i) / static_cast<float>(n));
  return out;
}

struct Best {
  std::optional<float> girth;
  float level = 0;
  GirthTape tape;
  void offer(std::optional<float> g, float y, bool want_max, const GirthTape& t) {
    if (!g) return;
    if (!girth || (want_max ? *g > *girth : *g < *girth)) {
      girth = g;
      level = y;
      tape = t;
    }
  }
  std::optional<GirthTape> taken() const { return girth ? std::optional<GirthTape>(tape) : std::nullopt; }
};

const glm::vec3 kUp{0, 1, 0};

}  // namespace

Result<BodyLandmarks> parse_makehuman_joints(std::string_view csv, float metres_per_unit, std::string_view source) {
  std::map<std::string, glm::vec3, std::less<>> joints;
  size_t pos = 0, line_no = 0;
  while (pos < csv.size()) {
    size_t eol = csv.find('\n', pos);
    if (eol == std::string_view::npos) eol = csv.size();
    std::string_view line = trim(csv.substr(pos, eol - pos));
    pos = eol + 1;
    ++line_no;
    if (line.empty() || line.front() == '#') continue;
    std::string_view f[4];
    int n = 0;
    size_t s = 0;
    for (; n < 4; ++n) {
      const size_t comma = line.find(',', s);
      f[n] = line.substr(s, comma == std::string_view::npos ? std::string_view::npos : comma - s);
      if (comma == std::string_view::npos) {
        ++n;
        break;
      }
      s = comma + 1;
      if (n == 3)
        return fail(Errc::parse_error, std::string(source) + ":" + std::to_string(line_no) + ": more than 4 fields");
    }
    if (n != 4)
      return fail(Errc::parse_error, std::string(source) + ":" + std::to_string(line_no) + ": expected name,x,y,z");
    if (trim(f[0]) == "name") continue;  // header row
    glm::vec3 p;
    for (int k = 0; k < 3; ++k)
      if (!parse_float(f[1 + k], p[k]))
        return fail(Errc::parse_error, std::string(source) + ":" + std::to_string(line_no) + ": bad number '" +
                                           std::string(trim(f[1 + k])) + "'");
    joints[std::string(trim(f[0]))] = p * metres_per_unit;
  }
  std::string missing;
  auto get = [&](const char* name) {
    auto it = joints.find(name);
    if (it != joints.end()) return it->second;
    missing += missing.empty() ? name : std::string(", ") + name;
    return glm::vec3(0);
  };
  BodyLandmarks lm;
  lm.ground_y_m = get("ground").y;
  lm.pelvis_m = get("pelvis");
  // Spine joints are optional (another skeleton may have fewer); spine-4 is the lowest.
  for (const char* s : {"spine-4", "spine-3", "spine-2", "spine-1"})
    if (auto it = joints.find(s); it != joints.end()) lm.spine_m.push_back(it->second);
  lm.neck_m = get("neck");
  lm.head_m = get("head");
  lm.head_top_m = get("head-2");
  for (auto [side, limb] : {std::pair{"l-", &lm.left}, std::pair{"r-", &lm.right}}) {
    const std::string p(side);
    limb->hip_m = get((p + "upper-leg").c_str());
    limb->knee_m = get((p + "knee").c_str());
    limb->ankle_m = get((p + "ankle").c_str());
    limb->shoulder_m = get((p + "shoulder").c_str());
    limb->elbow_m = get((p + "elbow").c_str());
    limb->wrist_m = get((p + "hand").c_str());
  }
  if (!missing.empty()) return fail(Errc::not_found, std::string(source) + ": missing joints: " + missing);
  return lm;
}

Result<BodyLandmarks> load_makehuman_joints(const std::string& csv_path, float metres_per_unit) {
  auto text = read_file(csv_path);
  if (!text) return tl::unexpected(text.error());
  return parse_makehuman_joints(*text, metres_per_unit, csv_path);
}

std::string format_landmarks_csv(const BodyLandmarks& lm, float units_per_metre) {
  std::string out = "# Body landmarks (joint centres), MakeHuman joint names, " + std::to_string(units_per_metre) +
                    " units per metre; +Y up, facing +Z, left +X\nname,x,y,z\n";
  auto row = [&](const std::string& name, glm::vec3 p) {
    char buf[160];
    p *= units_per_metre;
    std::snprintf(buf, sizeof buf, "%s,%.6f,%.6f,%.6f\n", name.c_str(), double(p.x), double(p.y), double(p.z));
    out += buf;
  };
  row("ground", {0, lm.ground_y_m, 0});
  row("pelvis", lm.pelvis_m);
  // The top spine joint is spine-1, as in MakeHuman; at most four are kept.
  const size_t n = std::min<size_t>(lm.spine_m.size(), 4);
  for (size_t i = 0; i < n; ++i) row("spine-" + std::to_string(n - i), lm.spine_m[i]);
  row("neck", lm.neck_m);
  row("head", lm.head_m);
  row("head-2", lm.head_top_m);
  for (auto [side, limb] : {std::pair{"l-", &lm.left}, std::pair{"r-", &lm.right}}) {
    const std::string p(side);
    row(p + "upper-leg", limb->hip_m);
    row(p + "knee", limb->knee_m);
    row(p + "ankle", limb->ankle_m);
    row(p + "shoulder", limb->shoulder_m);
    row(p + "elbow", limb->elbow_m);
    row(p + "hand", limb->wrist_m);
  }
  return out;
}

BodyLandmarks estimate_landmarks(const Mesh& mesh) {
  BodyLandmarks lm;
  if (mesh.positions.empty()) return lm;
  glm::vec3 lo = mesh.positions[0], hi = lo;
  for (const auto& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const float H = hi.y - lo.y, cx = 0.5f * (lo.x + hi.x);
  lm.ground_y_m = lo.y;
  // Centroid of the vertices in a band 2% of H thick at height fraction f, with x in [x0, x1].
  auto centroid = [&](float f, float x0, float x1) {
    const float y = lo.y + f * H;
    glm::dvec3 sum(0);
    double n = 0;
    for (const auto& p : mesh.positions)
      if (std::abs(p.y - y) < 0.01f * H && p.x >= x0 && p.x <= x1) {
        sum += glm::dvec3(p);
        n += 1;
      }
    return n > 0 ? glm::vec3(sum / n) : glm::vec3(cx, y, 0.5f * (lo.z + hi.z));
  };
  // Torso: within 0.1 H of the mirror plane, which keeps hanging arms and hands out.
  const float half = 0.1f * H;
  auto torso = [&](float f) {
    glm::vec3 c = centroid(f, cx - half, cx + half);
    return glm::vec3(cx, lo.y + f * H, c.z);
  };
  lm.pelvis_m = torso(0.53f);
  lm.spine_m = {torso(0.60f), torso(0.68f), torso(0.76f)};
  lm.neck_m = torso(0.84f);
  lm.head_m = torso(0.90f);
  lm.head_top_m = {cx, hi.y, lm.head_m.z};
  // Legs: the centroid of each side's band; hips sit a little inward of the upper thigh's centre.
  for (float side : {1.0f, -1.0f}) {
    LimbLandmarks& l = side > 0 ? lm.left : lm.right;
    auto leg = [&](float f) { return side > 0 ? centroid(f, cx, hi.x) : centroid(f, lo.x, cx); };
    l.knee_m = leg(0.285f);
    l.ankle_m = leg(0.045f);
    const glm::vec3 thigh = leg(0.44f);
    l.hip_m = {cx + 0.9f * (thigh.x - cx), lo.y + 0.52f * H, thigh.z};
    l.shoulder_m = l.elbow_m = l.wrist_m = glm::vec3(cx + side * 0.1f * H, lo.y + 0.82f * H, lm.neck_m.z);
  }
  return lm;
}

BodyLandmarks landmarks_from_skeleton(const rig::Skeleton& s, const rig::Pose& pose) {
  std::vector<rig::RigidTransform> w(s.joint_count());
  rig::forward_kinematics(s, pose, w);
  auto at = [&](const char* name) {
    const int j = s.find_joint(name);
    return j < 0 ? glm::vec3(0) : w[j].translation;
  };
  BodyLandmarks lm;
  float lowest = 0;
  for (int j = 0; j < s.joint_count(); ++j) {
    const float y = std::min(w[j].translation.y, w[j].apply(s.tip_m(j)).y);
    lowest = j == 0 ? y : std::min(lowest, y);
  }
  lm.ground_y_m = lowest - 0.018f;
  lm.pelvis_m = at("pelvis");
  for (const char* name : {"spine_lower", "spine_mid", "spine_upper"})
    if (s.find_joint(name) >= 0) lm.spine_m.push_back(at(name));
  lm.neck_m = at("neck");
  lm.head_m = at("head");
  const int head = s.find_joint("head");
  lm.head_top_m = head < 0 ? lm.head_m : w[head].apply(s.tip_m(head));
  for (auto [side, limb] : {std::pair{"l_", &lm.left}, std::pair{"r_", &lm.right}}) {
    const std::string p(side);
    limb->hip_m = at((p + "hip").c_str());
    limb->knee_m = at((p + "knee").c_str());
    limb->ankle_m = at((p + "ankle").c_str());
    limb->shoulder_m = at((p + "shoulder").c_str());
    limb->elbow_m = at((p + "elbow").c_str());
    limb->wrist_m = at((p + "wrist").c_str());
  }
  return lm;
}

BodyMeasurements measure_body(const Mesh& mesh, const BodyLandmarks& lm, GirthTapes* tapes) {
  BodyMeasurements m;
  if (tapes) *tapes = {};
  if (mesh.positions.empty()) return m;
  float top = mesh.positions[0].y;
  for (const auto& p : mesh.positions) top = std::max(top, p.y);
  const float ground = lm.ground_y_m, H = top - ground;
  m.height_m = H;
  for (size_t f = 0; f < mesh.triangle_count(); ++f) {
    const glm::dvec3 a(mesh.positions[mesh.indices[3 * f]]), b(mesh.positions[mesh.indices[3 * f + 1]]),
        c(mesh.positions[mesh.indices[3 * f + 2]]);
    m.volume_m3 += glm::dot(a, glm::cross(b, c)) / 6.0;
    m.surface_area_m2 += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  const LimbLandmarks& L = lm.left;
  const LimbLandmarks& R = lm.right;

  // Torso slices: the loop around the spine axis, refusing loops that swallowed an arm.
  auto torso_girth = [&](float y, bool wrap_thighs, GirthTape& t) -> std::optional<float> {
    const glm::vec3 axis = torso_axis_at(lm, y);
    t = {axis, kUp, {axis}, {}};
    for (const LimbLandmarks* s : {&L, &R})
      for (auto seg : {std::pair{s->shoulder_m, s->elbow_m}, std::pair{s->elbow_m, s->wrist_m}})
        if (auto p = segment_at(seg.first, seg.second, y)) t.exclude.push_back(*p);
    if (auto g = tape_girth(mesh, t)) return g;
    if (!wrap_thighs) return std::nullopt;
    // Below the crotch the tape goes round both thighs.
    t.include.clear();
    for (const LimbLandmarks* s : {&L, &R})
      if (auto p = segment_at(s->hip_m, s->knee_m, y, true)) t.include.push_back(*p);
    return tape_girth(mesh, t);
  };
  auto search = [&](float from_h, float to_h, bool want_max, bool wrap_thighs) {
    Best best;
    GirthTape t;
    for (float y : levels(ground + from_h * H, ground + to_h * H))
      best.offer(torso_girth(y, wrap_thighs, t), y - ground, want_max, t);
    return best;
  };
  // Chest, bottom up, stopping at the armpit: where the torso loop suddenly grows by more than
  // 15% in one 5 mm step it has taken in an arm (this also guards landmarks without arms).
  Best chest;
  {
    std::optional<float> previous;
    GirthTape t;
    for (float y : levels(ground + 0.68f * H, ground + 0.76f * H)) {
      const auto g = torso_girth(y, false, t);
      if (g && previous && *g > 1.15f * *previous) break;
      chest.offer(g, y - ground, true, t);
      previous = g;
    }
  }
  const Best waist = search(0.56f, 0.66f, false, false);
  // Hips: the torso's own loops; only a body whose torso splits below the whole range gets the
  // tape round both thighs (wrapping them everywhere would let spreading legs win).
  Best hips = search(0.45f, 0.54f, true, false);
  if (!hips.girth) hips = search(0.45f, 0.54f, true, true);
  std::tie(m.chest_girth_m, m.chest_level_m) = std::pair(chest.girth, chest.level);
  std::tie(m.waist_girth_m, m.waist_level_m) = std::pair(waist.girth, waist.level);
  std::tie(m.hip_girth_m, m.hip_level_m) = std::pair(hips.girth, hips.level);

  // Leg slices: the loop around this leg's axis that holds neither the torso axis nor the other leg.
  auto leg_search = [&](float y0, float y1, const glm::vec3& a, const glm::vec3& b, const glm::vec3& oa,
                        const glm::vec3& ob) {
    Best best;
    for (float y : levels(y0, y1)) {
      const auto axis = segment_at(a, b, y, true);
      if (!axis) continue;
      GirthTape t{*axis, kUp, {*axis}, {torso_axis_at(lm, y)}};
      if (auto other = segment_at(oa, ob, y, true)) t.exclude.push_back(*other);
      best.offer(tape_girth(mesh, t), y - ground, true, t);
    }
    return best;
  };
  const Best thigh =
      leg_search(L.hip_m.y, L.hip_m.y + (L.knee_m.y - L.hip_m.y) / 3.0f, L.hip_m, L.knee_m, R.hip_m, R.knee_m);
  const Best calf =
      leg_search(L.knee_m.y, L.knee_m.y + 0.6f * (L.ankle_m.y - L.knee_m.y), L.knee_m, L.ankle_m, R.knee_m, R.ankle_m);
  std::tie(m.thigh_girth_m, m.thigh_level_m) = std::pair(thigh.girth, thigh.level);
  std::tie(m.calf_girth_m, m.calf_level_m) = std::pair(calf.girth, calf.level);
  std::optional<GirthTape> arm;
  {
    const glm::vec3 mid = 0.5f * (L.shoulder_m + L.elbow_m), dir = L.elbow_m - L.shoulder_m;
    if (glm::length(dir) > 1e-6f) {
      arm = GirthTape{mid, dir, {mid}, {}};
      m.upper_arm_girth_m = tape_girth(mesh, *arm);
      if (!m.upper_arm_girth_m) arm.reset();
    }
  }
  if (tapes) *tapes = {chest.taken(), waist.taken(), hips.taken(), thigh.taken(), calf.taken(), arm};
  return m;
}

std::vector<MeasurementRow> measurement_rows(const BodyMeasurements& m) {
  std::vector<MeasurementRow> rows;
  rows.push_back({"height", "height", "cm", 100.0 * m.height_m});
  auto girth = [&](const char* name, const char* key, const std::optional<float>& g) {
    if (g) rows.push_back({name, key, "cm", 100.0 * *g});
  };
  girth("chest girth", "chest_girth", m.chest_girth_m);
  girth("waist girth", "waist_girth", m.waist_girth_m);
  girth("hip girth", "hip_girth", m.hip_girth_m);
  girth("thigh girth (left)", "thigh_girth", m.thigh_girth_m);
  girth("calf girth (left)", "calf_girth", m.calf_girth_m);
  girth("upper arm girth (left)", "upper_arm_girth", m.upper_arm_girth_m);
  rows.push_back({"volume", "volume", "dm3", 1000.0 * m.volume_m3});
  rows.push_back({"surface area", "surface_area", "m2", m.surface_area_m2});
  return rows;
}

std::string format_measurements(const BodyMeasurements& m) {
  std::string out;
  char buf[160];
  std::snprintf(buf, sizeof buf, "%-24s %10s  %s\n", "measurement", "value", "unit");
  out += buf;
  for (const auto& r : measurement_rows(m)) {
    std::snprintf(buf, sizeof buf, r.unit == "m2" ? "%-24s %10.3f  %s\n" : "%-24s %10.2f  %s\n", r.name.c_str(),
                  r.value, r.unit.c_str());
    out += buf;
  }
  std::snprintf(buf, sizeof buf, "levels above ground (cm): chest %.1f, waist %.1f, hips %.1f, thigh %.1f, calf %.1f\n",
                100.0 * m.chest_level_m, 100.0 * m.waist_level_m, 100.0 * m.hip_level_m, 100.0 * m.thigh_level_m,
                100.0 * m.calf_level_m);
  out += buf;
  return out;
}

std::string measurements_json(const BodyMeasurements& m) {
  nlohmann::ordered_json j;
  for (const auto& r : measurement_rows(m)) j[r.key + "_" + r.unit] = r.value;
  nlohmann::ordered_json levels;
  levels["chest"] = m.chest_level_m;
  levels["waist"] = m.waist_level_m;
  levels["hips"] = m.hip_level_m;
  levels["thigh"] = m.thigh_level_m;
  levels["calf"] = m.calf_level_m;
  j["levels_above_ground_m"] = levels;
  return j.dump(2);
}

namespace {

struct ComparedRow {
  MeasurementRow ref;
  std::optional<double> ours;
  std::optional<double> difference;  // (ours − ref) / ref
  bool pass = false;
};

std::vector<ComparedRow> compare(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance) {
  std::vector<ComparedRow> out;
  const auto ours_rows = measurement_rows(ours);
  auto ref_rows = measurement_rows(reference);
  // Keep rows that only one side has, so a missing girth shows up as a failure.
  for (const auto& r : ours_rows)
    if (std::none_of(ref_rows.begin(), ref_rows.end(), [&](const MeasurementRow& x) { return x.key == r.key; }))
      ref_rows.push_back({r.name, r.key, r.unit, std::nan("")});
  for (const auto& r : ref_rows) {
    ComparedRow c{r, std::nullopt, std::nullopt, false};
    for (const auto& o : ours_rows)
      if (o.key == r.key) c.ours = o.value;
    if (c.ours && std::isfinite(r.value) && r.value != 0) {
      c.difference = (*c.ours - r.value) / r.value;
      c.pass = std::abs(*c.difference) <= tolerance;
    }
    out.push_back(c);
  }
  return out;
}

}  // namespace

std::string format_comparison(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance) {
  std::string out;
  char buf[200];
  char limit[32];
  std::snprintf(limit, sizeof limit, "within ±%g%%", 100.0 * tolerance);
  std::snprintf(buf, sizeof buf, "%-24s %10s %10s %8s  %s\n", "measurement", "ours", "reference", "diff %", limit);
  out += buf;
  auto num = [](std::optional<double> v, const char* fmt) {
    char b[32];
    if (!v || !std::isfinite(*v)) return std::string("n/a");
    std::snprintf(b, sizeof b, fmt, *v);
    return std::string(b);
  };
  for (const auto& c : compare(ours, reference, tolerance)) {
    const std::string label = c.ref.name + " (" + c.ref.unit + ")";
    const std::optional<double> diff = c.difference ? std::optional<double>(100.0 * *c.difference) : std::nullopt;
    const char* fmt = c.ref.unit == "m2" ? "%.3f" : "%.2f";
    std::snprintf(buf, sizeof buf, "%-24s %10s %10s %8s  %s\n", label.c_str(), num(c.ours, fmt).c_str(),
                  num(c.ref.value, fmt).c_str(), num(diff, "%+.1f").c_str(), c.pass ? "PASS" : "FAIL");
    out += buf;
  }
  return out;
}

std::string comparison_json(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance) {
  nlohmann::ordered_json j;
  j["tolerance"] = tolerance;
  bool all = true;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const auto& c : compare(ours, reference, tolerance)) {
    nlohmann::ordered_json r;
    r["key"] = c.ref.key;
    r["unit"] = c.ref.unit;
    r["ours"] = c.ours && std::isfinite(*c.ours) ? nlohmann::ordered_json(*c.ours) : nlohmann::ordered_json();
    r["reference"] = std::isfinite(c.ref.value) ? nlohmann::ordered_json(c.ref.value) : nlohmann::ordered_json();
    r["difference"] = c.difference ? nlohmann::ordered_json(*c.difference) : nlohmann::ordered_json();
    r["pass"] = c.pass;
    all = all && c.pass;
    rows.push_back(r);
  }
  j["pass"] = all;
  j["rows"] = rows;
  return j.dump(2);
}

bool comparison_passes(const BodyMeasurements& ours, const BodyMeasurements& reference, double tolerance) {
  const auto rows = compare(ours, reference, tolerance);
  return std::all_of(rows.begin(), rows.end(), [](const ComparedRow& c) { return c.pass; });
}

}  // namespace mimic::avatar
