// mimic intersect: where the posed skin passes through itself, exactly (CGAL's predicates, the
// avatar/exact library), frame by frame over a clip, a built-in motion or a recorded session.
#if MIMIC_HAVE_EXACT  // built when CGAL is found (avatar/exact)

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "body_posing.h"
#include "cli.h"
#include "command.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/self_intersection.h"
#include "mimic/avatar/skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/rig/bvh.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/retarget.h"
#include "mimic/service/solve_log.h"

namespace mimic::app::cmd_intersect {
namespace {

constexpr const char* kName = "intersect";
constexpr const char* kAbout =
    "Checks the posed skin for self-intersection with exact predicates, every Nth frame of BVH\n"
    "clips, a built-in motion or a recorded session, or one posture: pairs of intersecting\n"
    "triangles inside one skin piece (folds), pairs between two pieces, the deepest\n"
    "interpenetration (how far a vertex of one piece lies inside another piece's closed surface)\n"
    "and the sharpest crease between neighbouring envelope triangles. The rigid head, hands and\n"
    "feet sinking into the piece they attach to (neck, forearm, calf) is by design: counted apart,\n"
    "not as an intersection (docs/skin.md, \"Self-intersection\"). One line per frame, then a\n"
    "summary per source, method and LOD; progress on stderr every 10 s.\n"
    "Targets: 0 folds, <= 5 pairs between pieces a frame on average, no interpenetration deeper\n"
    "than 5 mm, no crease sharper than 90 deg.";

struct Options {
  std::vector<std::string> bvh;
  std::string motion, log, calibration, pose, body, lods = "0", methods = "realtime";
  long every = 10, max_frames = 0;
  double fps = 30, seconds = 0;
  int subdivision = 0;
  bool no_muscles = false, no_contact = false, json = false, summary_only = false, where = false;
};

struct Source {
  std::string name;
  std::vector<rig::Pose> poses;
  std::vector<long> frames;  // each pose's frame (BVH) or sample (motion, session) number
};

Result<std::vector<int>> parse_lods(const std::string& text) {
  if (text == "all") return std::vector<int>{0, 1, 2, 3};
  std::vector<int> lods;
  size_t at = 0;
  while (at <= text.size()) {
    const size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    if (item.size() != 1 || item[0] < '0' || item[0] >= '0' + avatar::kSkinLodCount)
      return fail(Errc::invalid_argument, "--lod takes 0-3, a list such as 0,2, or all; got '" + text + "'");
    lods.push_back(item[0] - '0');
    at = comma + 1;
  }
  return lods;
}

std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  auto& app = p.app();
  auto* bvh = app.add_option("--bvh", o.bvh, "BVH clips (CMU units), retargeted onto the body's skeleton")
                  ->type_name("CLIP...")
                  ->expected(1, -1);
  auto* motion = app.add_option("--motion", o.motion, "a built-in motion (one loop, sampled at --fps)")
                     ->check(CLI::IsMember(rig::builtin_motion_names()));
  auto* log = app.add_option("--log", o.log,
                             "a recorded tracker session (mimic record), solved frame by frame as\n"
                             "mimic run --source replay: would, at --fps")
                  ->type_name("SESSION.mlog");
  app.add_option("--calibration", o.calibration, "the wearer's calibration for --log (their fitted skeleton)")
      ->type_name("FILE")
      ->needs(log);
  auto* pose = app.add_option("--pose", o.pose, "one posture: zero (the T-pose the body is authored in) or rest")
                   ->check(CLI::IsMember({"zero", "rest"}));
  bvh->excludes(motion)->excludes(log)->excludes(pose);
  motion->excludes(log)->excludes(pose);
  log->excludes(pose);
  app.add_option("--body", o.body, "body model or preset:NAME (default: the built-in body)")->type_name("FILE");
  app.add_option("--lod", o.lods, "skin levels of detail: 0-3, a list (0,2) or all (default 0)")
      ->type_name("LODS")
      ->check(cli::parsed_by(parse_lods, "LODS"));
  app.add_option("--method", o.methods, "realtime (default), full, or both")
      ->check(CLI::IsMember({"realtime", "full", "both"}));
  app.add_option("--every", o.every, "check every Nth frame (default 10)")->check(CLI::Range(1L, 1000000L));
  app.add_option("--frames", o.max_frames, "at most N checked frames per source (default: all)")
      ->check(CLI::Range(1L, 100000000L));
  app.add_option("--fps", o.fps, "samples per second of --motion and --log (default 30)")
      ->check(cli::finite_range(0, 1000, cli::Bound::exclusive));
  app.add_option("--seconds", o.seconds, "at most S seconds of --motion or --log (default: one loop, all of it)")
      ->check(cli::finite_range(0, 3600, cli::Bound::exclusive));
  app.add_option("--subdivision", o.subdivision,
                 "the full method's B-spline samples per span (default 0: the\n"
                 "contour points, the realtime method's mesh)")
      ->check(CLI::Range(0, 3));
  app.add_flag("--no-muscles", o.no_muscles, "the realtime method without its muscle terms");
  app.add_flag("--no-contact", o.no_contact, "the realtime method without contact between its pieces");
  app.add_flag("--json", o.json, "one JSON object a line: each frame, then each summary");
  app.add_flag("--summary", o.summary_only, "only the summaries, no line per frame");
  app.add_flag("--where", o.where, "name the rings each fold lies in (ring:column), each frame and summary");
  if (auto exit_code = p.parse(argv)) return exit_code;
  if (bvh->count() + motion->count() + log->count() + pose->count() == 0)
    return p.usage_error("give --bvh CLIP..., --motion NAME, --log SESSION.mlog or --pose zero|rest");
  return std::nullopt;
}

std::string stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string s = slash == std::string::npos ? path : path.substr(slash + 1);
  if (s.size() > 4 && s.ends_with(".bvh")) s.resize(s.size() - 4);
  return s;
}

// Every `every`th pose of each source, on `skeleton` (the body's, or --log's fitted one, which
// replaces it).
Result<std::vector<Source>> load_sources(const Options& o, rig::Skeleton& skeleton) {
  std::vector<Source> sources;
  const auto keep = [&](const Source& s) {
    return o.max_frames == 0 || static_cast<long>(s.poses.size()) < o.max_frames;
  };
  for (const std::string& path : o.bvh) {
    auto clip = rig::load_bvh(path);
    if (!clip) return tl::unexpected(clip.error());
    auto r = rig::retarget_bvh(*clip);
    if (!r) return tl::unexpected(r.error());
    Source s{stem(path), {}, {}};
    for (size_t f = 0; f < r->poses.size() && keep(s); f += size_t(o.every)) {
      s.poses.push_back(rig::transfer_pose(r->skeleton, r->poses[f], skeleton));
      s.frames.push_back(long(f));
    }
    sources.push_back(std::move(s));
  }
  if (!o.motion.empty()) {
    auto m = rig::make_builtin_motion(o.motion, skeleton);
    if (!m) return tl::unexpected(m.error());
    const double span_s = o.seconds > 0 ? o.seconds : (*m)->duration_s();
    Source s{o.motion, {}, {}};
    rig::Pose pose = skeleton.zero_pose();
    for (long k = 0; double(k) / o.fps <= span_s && keep(s); k += o.every) {
      (*m)->sample(double(k) / o.fps, pose);
      s.poses.push_back(pose);
      s.frames.push_back(k);
    }
    sources.push_back(std::move(s));
  }
  if (!o.pose.empty()) {
    rig::Pose pose = o.pose == "zero" ? skeleton.zero_pose() : avatar::relaxed_posture(skeleton);
    pose.root_position_m.y = rig::standing_root_height_m(skeleton);
    sources.push_back(Source{o.pose, {pose}, {0}});
  }
  if (!o.log.empty()) {
    auto take = service::solve_log(o.log, o.calibration, o.fps, &skeleton, o.seconds);
    if (!take) return tl::unexpected(take.error());
    skeleton = take->skeleton;
    Source s{stem(o.log), {}, {}};
    for (size_t k = 0; k < take->poses.size() && keep(s); k += size_t(o.every)) {
      s.poses.push_back(take->poses[k]);
      s.frames.push_back(long(k));
    }
    sources.push_back(std::move(s));
  }
  return sources;
}

// One method at one LOD: poses in, the posed mesh out.
class Skinner {
 public:
  static Result<Skinner> create(const avatar::BodyModel& body, const rig::Skeleton& sk, avatar::SkinMethod method,
                                int lod, const Options& o) {
    Skinner s;
    s.muscles_ = !o.no_muscles;
    s.contact_ = !o.no_contact;
    if (method == avatar::SkinMethod::realtime) {
      avatar::RealtimeOptions ro;
      ro.lod = lod;
      ro.contact = s.contact_;
      auto b = avatar::RealtimeBody::create(body, sk, ro);
      if (!b) return tl::unexpected(b.error());
      s.mesh_ = (*b)->rest_mesh();
      s.realtime_ = std::make_unique<avatar::RealtimeSkin>(*b);
    } else {
      avatar::SkinOptions so;
      so.subdivision = o.subdivision;
      so.normals = false;
      auto f = avatar::ImplicitSkin::create(avatar::with_skin_lod(body, lod), sk, so);
      if (!f) return tl::unexpected(f.error());
      s.full_ = std::make_unique<avatar::ImplicitSkin>(std::move(*f));
      s.mesh_ = s.full_->mesh();
    }
    if (o.where) {
      // The realtime mesh's vertices are the full method's at subdivision 0: the layout's control
      // points, ring after ring; what is beyond them (rigid parts, or B-spline samples) is
      // named by its part.
      // The full method at subdivision 0 has its own skin to name them by.
      if (method == avatar::SkinMethod::realtime || o.subdivision == 0) {
        std::unique_ptr<avatar::ImplicitSkin> own;
        if (!s.full_) {
          avatar::SkinOptions so;
          so.subdivision = 0;
          so.normals = false;
          auto f = avatar::ImplicitSkin::create(avatar::with_skin_lod(body, lod), sk, so);
          if (!f) return tl::unexpected(f.error());
          own = std::make_unique<avatar::ImplicitSkin>(std::move(*f));
        }
        for (const auto& ring : (s.full_ ? *s.full_ : *own).contours())
          for (size_t i = 0; i < ring.points.size(); ++i)
            s.vertex_label_.push_back(ring.name + ":" + std::to_string(i));
      }
      s.triangle_part_.resize(s.mesh_.triangle_count());
      for (const avatar::MeshPart& part : s.mesh_.parts)
        for (uint32_t t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t)
          s.triangle_part_[t] = part.name;
    }
    return s;
  }
  const std::string& triangle_part(uint32_t t) const { return triangle_part_.at(t); }
  // A triangle's rings (the strip between two rings: "a+b") and the column of its first point,
  // or its part's name beyond the contours.
  std::string triangle_label(uint32_t t) const {
    const uint32_t* v = &mesh_.indices[3 * size_t(t)];
    const uint32_t first = std::min({v[0], v[1], v[2]});
    if (std::max({v[0], v[1], v[2]}) >= vertex_label_.size())
      return t < triangle_part_.size() ? triangle_part_[t] : std::string("?");
    std::vector<std::string> rings;
    for (int k = 0; k < 3; ++k) {
      const std::string& l = vertex_label_[v[k]];
      rings.push_back(l.substr(0, l.find(':')));
    }
    std::sort(rings.begin(), rings.end());
    rings.erase(std::unique(rings.begin(), rings.end()), rings.end());
    std::string label = rings[0];
    for (size_t k = 1; k < rings.size(); ++k) label += "+" + rings[k];
    const std::string& f = vertex_label_[first];
    return label + f.substr(f.find(':'));
  }
  const avatar::Mesh& topology() const { return mesh_; }
  const avatar::Mesh& pose(const rig::Pose& p) {
    if (realtime_) {
      realtime_->evaluate(p, mesh_.positions, {}, muscles_, contact_);
      return mesh_;
    }
    full_->evaluate(p);
    return full_->mesh();
  }

 private:
  std::unique_ptr<avatar::RealtimeSkin> realtime_;
  std::unique_ptr<avatar::ImplicitSkin> full_;
  avatar::Mesh mesh_;
  bool muscles_ = true, contact_ = true;
  std::vector<std::string> vertex_label_, triangle_part_;
};

// Counts by name, the largest first.
std::vector<std::pair<std::string, size_t>> most_first(const std::map<std::string, size_t>& count) {
  std::vector<std::pair<std::string, size_t>> out(count.begin(), count.end());
  std::stable_sort(out.begin(), out.end(), [](const auto& x, const auto& y) { return x.second > y.second; });
  return out;
}

// The rings holding the folds (pairs inside one part), as "ring:column" pairs, most first.
std::vector<std::pair<std::string, size_t>> fold_places(const Skinner& skinner, const avatar::IntersectionReport& r) {
  std::map<std::string, size_t> count;
  for (const auto& [a, b] : r.triangle_pairs) {
    if (skinner.triangle_part(a) != skinner.triangle_part(b)) continue;
    const std::string la = skinner.triangle_label(a), lb = skinner.triangle_label(b);
    ++count[la < lb ? la + " " + lb : lb + " " + la];
  }
  return most_first(count);
}

struct Summary {
  Summary(std::string source_name, std::string method_name, int level)
      : source(std::move(source_name)), method(std::move(method_name)), lod(level) {}
  std::string source, method;
  int lod = 0;
  size_t triangles = 0, frames = 0, frames_folding = 0, frames_crossing = 0, frames_creased = 0;
  double folds = 0, between = 0, by_design = 0, deepest_mm = 0, envelope_mm = 0, crease_deg = 0;  // sums
  size_t folds_max = 0, between_max = 0;
  double deepest_mm_max = 0, envelope_mm_max = 0, crease_deg_max = 0;
  std::string deepest_where, envelope_where, crease_where;
  std::map<std::pair<std::string, std::string>, size_t> by_parts;  // by-design pairs left out
  std::map<std::string, size_t> fold_rings;                        // --where: ring pairs, columns left out

  void add_places(const std::vector<std::pair<std::string, size_t>>& places) {
    const auto ring = [](const std::string& l) { return l.substr(0, l.find(':')); };
    for (const auto& [where, n] : places) {
      const size_t gap = where.find(' ');
      const std::string a = ring(where.substr(0, gap)), b = ring(where.substr(gap + 1));
      fold_rings[a == b ? a : a + " " + b] += n;
    }
  }
  void add(const avatar::IntersectionReport& r, const std::string& frame) {
    triangles = r.triangles;
    ++frames;
    frames_folding += r.fold_pairs > 0;
    frames_crossing += r.between_pairs > 0;
    frames_creased += r.sharpest_crease_deg > 90;
    folds += double(r.fold_pairs), between += double(r.between_pairs), by_design += double(r.by_design_pairs);
    deepest_mm += 1000 * r.deepest_m, envelope_mm += 1000 * r.deepest_envelope_m;
    crease_deg += r.sharpest_crease_deg;
    if (1000 * r.deepest_envelope_m > envelope_mm_max) {
      envelope_mm_max = 1000 * r.deepest_envelope_m;
      envelope_where = r.deepest_envelope_part + " in " + r.deepest_envelope_inside + ", " + frame;
    }
    folds_max = std::max(folds_max, r.fold_pairs), between_max = std::max(between_max, r.between_pairs);
    if (1000 * r.deepest_m > deepest_mm_max) {
      deepest_mm_max = 1000 * r.deepest_m;
      deepest_where = r.deepest_part + " in " + r.deepest_inside + ", " + frame;
    }
    if (r.sharpest_crease_deg > crease_deg_max)
      crease_deg_max = r.sharpest_crease_deg, crease_where = r.crease_part + ", " + frame;
    for (const auto& p : r.by_parts)
      if (!p.by_design) by_parts[{p.a, p.b}] += p.pairs;
  }
  void merge(const Summary& s) {
    triangles = s.triangles;
    frames += s.frames, frames_folding += s.frames_folding, frames_crossing += s.frames_crossing;
    frames_creased += s.frames_creased;
    folds += s.folds, between += s.between, by_design += s.by_design, deepest_mm += s.deepest_mm;
    envelope_mm += s.envelope_mm;
    for (const auto& [k, n] : s.fold_rings) fold_rings[k] += n;
    if (s.envelope_mm_max > envelope_mm_max) envelope_mm_max = s.envelope_mm_max, envelope_where = s.envelope_where;
    crease_deg += s.crease_deg;
    folds_max = std::max(folds_max, s.folds_max), between_max = std::max(between_max, s.between_max);
    if (s.deepest_mm_max > deepest_mm_max) deepest_mm_max = s.deepest_mm_max, deepest_where = s.deepest_where;
    if (s.crease_deg_max > crease_deg_max) crease_deg_max = s.crease_deg_max, crease_where = s.crease_where;
    for (const auto& [k, n] : s.by_parts) by_parts[k] += n;
  }
  // The part pairs with most intersections, as "a/b n.n" per frame.
  std::vector<std::pair<std::string, double>> top(size_t n) const {
    std::vector<std::pair<std::string, double>> v;
    for (const auto& [k, c] : by_parts)
      v.emplace_back(k.first == k.second ? k.first : k.first + "/" + k.second, double(c) / double(frames));
    std::stable_sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
    if (v.size() > n) v.resize(n);
    return v;
  }
};

nlohmann::ordered_json frame_json(const Summary& where, long frame, const avatar::IntersectionReport& r) {
  nlohmann::ordered_json j{{"source", where.source},
                           {"method", where.method},
                           {"lod", where.lod},
                           {"frame", frame},
                           {"triangles", r.triangles},
                           {"fold_pairs", r.fold_pairs},
                           {"between_pairs", r.between_pairs},
                           {"by_design_pairs", r.by_design_pairs},
                           {"deepest_mm", 1000 * r.deepest_m},
                           {"deepest_part", r.deepest_part},
                           {"deepest_inside", r.deepest_inside},
                           {"deepest_envelope_mm", 1000 * r.deepest_envelope_m},
                           {"deepest_envelope_part", r.deepest_envelope_part},
                           {"deepest_envelope_inside", r.deepest_envelope_inside},
                           {"sharpest_crease_deg", r.sharpest_crease_deg},
                           {"crease_part", r.crease_part}};
  auto& parts = j["by_parts"] = nlohmann::ordered_json::array();
  for (const auto& p : r.by_parts)
    parts.push_back({{"a", p.a}, {"b", p.b}, {"pairs", p.pairs}, {"by_design", p.by_design}});
  return j;
}

void print_frame(const Summary& where, long frame, const avatar::IntersectionReport& r) {
  std::printf("%s %s lod %d frame %ld: folds %zu, between %zu (by design %zu), deepest %.1f mm", where.source.c_str(),
              where.method.c_str(), where.lod, frame, r.fold_pairs, r.between_pairs, r.by_design_pairs,
              1000 * r.deepest_m);
  if (r.deepest_m > 0) std::printf(" (%s in %s)", r.deepest_part.c_str(), r.deepest_inside.c_str());
  if (r.deepest_envelope_m > 0 && r.deepest_envelope_m < r.deepest_m)
    std::printf(", between skin pieces %.1f mm (%s in %s)", 1000 * r.deepest_envelope_m,
                r.deepest_envelope_part.c_str(), r.deepest_envelope_inside.c_str());
  std::printf(", crease %.1f deg (%s)", r.sharpest_crease_deg, r.crease_part.c_str());
  int shown = 0;  // the three part pairs with most intersections, by-design pairs left out
  for (const auto& p : r.by_parts) {
    if (p.by_design || shown == 3) continue;
    std::printf("%s %s%s%s %zu", shown++ == 0 ? ";" : ",", p.a.c_str(), p.a == p.b ? "" : "/",
                p.a == p.b ? "" : p.b.c_str(), p.pairs);
  }
  std::printf("\n");
}

nlohmann::ordered_json summary_json(const Summary& s) {
  const double n = double(std::max<size_t>(s.frames, 1));
  nlohmann::ordered_json j{{"summary", s.source},
                           {"method", s.method},
                           {"lod", s.lod},
                           {"triangles", s.triangles},
                           {"frames", s.frames},
                           {"frames_folding", s.frames_folding},
                           {"frames_crossing", s.frames_crossing},
                           {"fold_pairs_mean", s.folds / n},
                           {"fold_pairs_max", s.folds_max},
                           {"between_pairs_mean", s.between / n},
                           {"between_pairs_max", s.between_max},
                           {"by_design_pairs_mean", s.by_design / n},
                           {"deepest_mm_mean", s.deepest_mm / n},
                           {"deepest_mm_max", s.deepest_mm_max},
                           {"deepest_where", s.deepest_where},
                           {"deepest_envelope_mm_mean", s.envelope_mm / n},
                           {"deepest_envelope_mm_max", s.envelope_mm_max},
                           {"deepest_envelope_where", s.envelope_where},
                           {"sharpest_crease_deg_mean", s.crease_deg / n},
                           {"sharpest_crease_deg_max", s.crease_deg_max},
                           {"crease_where", s.crease_where},
                           {"frames_crease_over_90_deg", s.frames_creased}};
  for (const auto& [k, v] : s.top(8)) j["pairs_per_frame"][k] = v;
  for (const auto& [k, v] : s.fold_rings) j["folds_per_frame_by_ring"][k] = double(v) / n;
  return j;
}

void print_summaries(const std::vector<Summary>& all) {
  std::printf("\n%-10s %-8s %3s %6s %6s | %-13s | %-13s | %-10s | %-10s | %-9s | %s\n", "source", "method", "lod",
              "tris", "frames", "folds mean/max", "between m/max", "deep mm", "skin mm", "crease",
              "frames folding / crossing / crease > 90");
  for (const Summary& s : all) {
    const double n = double(std::max<size_t>(s.frames, 1));
    std::printf(
        "%-10s %-8s %3d %6zu %6zu | %6.1f %6zu | %6.1f %6zu | %4.1f %5.1f | %4.1f %5.1f | %4.0f %4.0f | %zu / %zu / "
        "%zu\n",
        s.source.c_str(), s.method.c_str(), s.lod, s.triangles, s.frames, s.folds / n, s.folds_max, s.between / n,
        s.between_max, s.deepest_mm / n, s.deepest_mm_max, s.envelope_mm / n, s.envelope_mm_max, s.crease_deg / n,
        s.crease_deg_max, s.frames_folding, s.frames_crossing, s.frames_creased);
  }
  std::printf(
      "(mean and max a frame; deep: any part in another, skin: between skin pieces only, no rigid part;\n"
      " targets: folds 0, between <= 5 mean, deepest <= 5 mm, crease <= 90 deg)\n");
  for (const Summary& s : all) {
    std::printf(
        "%s %s lod %d: deepest %.1f mm (%s), between skin pieces %.1f mm (%s); sharpest %.1f deg (%s); "
        "pairs a frame:",
        s.source.c_str(), s.method.c_str(), s.lod, s.deepest_mm_max, s.deepest_where.c_str(), s.envelope_mm_max,
        s.envelope_where.c_str(), s.crease_deg_max, s.crease_where.c_str());
    for (const auto& [k, v] : s.top(5)) std::printf(" %s %.1f", k.c_str(), v);
    std::printf("\n");
    if (s.fold_rings.empty()) continue;
    const auto rings = most_first(s.fold_rings);
    std::printf("  folds a frame by ring:");
    for (size_t i = 0; i < std::min<size_t>(rings.size(), 8); ++i)
      std::printf("%s %s %.2f", i ? "," : "", rings[i].first.c_str(), double(rings[i].second) / double(s.frames));
    std::printf("\n");
  }
}

// Progress on stderr every 10 s, with the time left at the rate so far.
class Progress {
 public:
  explicit Progress(size_t total) : total_(total) {}
  void step() {
    ++done_;
    const auto now = std::chrono::steady_clock::now();
    if (now < next_) return;
    next_ = now + std::chrono::seconds(10);
    const double elapsed_s = std::chrono::duration<double>(now - start_).count();
    const double left_s = elapsed_s / double(done_) * double(total_ - done_);
    std::fprintf(stderr, "mimic intersect: %zu of %zu frames, %.0f s, about %.0f s left\n", done_, total_, elapsed_s,
                 left_s);
  }

 private:
  size_t total_, done_ = 0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(),
                                        next_ = start_ + std::chrono::seconds(10);
};

int run(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  p->footer("exit status: 0 measured (whatever it found), 1 failure, 2 usage error");
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  const std::vector<int> lods = *parse_lods(o.lods);
  std::vector<avatar::SkinMethod> methods;
  if (o.methods != "full") methods.push_back(avatar::SkinMethod::realtime);
  if (o.methods != "realtime") methods.push_back(avatar::SkinMethod::full);
  auto body = body_from_path(o.body);
  if (!body) return failure(kName, body.error().what());
  auto skeleton = rig::Skeleton::build(body->skeleton);
  if (!skeleton) return failure(kName, skeleton.error().what());
  auto sources = load_sources(o, *skeleton);
  if (!sources) return failure(kName, sources.error().what());
  size_t total = 0;
  for (const Source& s : *sources) total += s.poses.size() * lods.size() * methods.size();
  Progress progress(total);
  std::vector<Summary> summaries;
  std::map<std::pair<std::string, int>, Summary> overall;  // (method, LOD) over every source
  for (int lod : lods)
    for (avatar::SkinMethod method : methods) {
      auto skinner = Skinner::create(*body, *skeleton, method, lod, o);
      if (!skinner) return failure(kName, skinner.error().what());
      auto checker = avatar::SelfIntersectionChecker::create(skinner->topology());
      if (!checker) return failure(kName, checker.error().what());
      for (const Source& src : *sources) {
        Summary sum{src.name, avatar::skin_method_name(method), lod};
        for (size_t k = 0; k < src.poses.size(); ++k) {
          const avatar::IntersectionReport r = checker->check(skinner->pose(src.poses[k]).positions);
          sum.add(r, "frame " + std::to_string(src.frames[k]) + " of " + src.name);
          std::vector<std::pair<std::string, size_t>> places;
          if (o.where) sum.add_places(places = fold_places(*skinner, r));
          if (!o.summary_only && o.json) {
            auto j = frame_json(sum, src.frames[k], r);
            if (o.where) j["folds_where"] = places;
            std::printf("%s\n", j.dump().c_str());
          }
          if (!o.summary_only && !o.json) {
            print_frame(sum, src.frames[k], r);
            for (size_t i = 0; i < std::min<size_t>(places.size(), 4); ++i)
              std::printf("%s %s %zu", i ? "," : "  folds:", places[i].first.c_str(), places[i].second);
            if (!places.empty()) std::printf("\n");
          }
          std::fflush(stdout);
          progress.step();
        }
        summaries.push_back(sum);
        auto [it, added] = overall.try_emplace({sum.method, lod}, Summary{"all", sum.method, lod});
        it->second.merge(sum);
      }
    }
  if (sources->size() > 1)
    for (const auto& [k, s] : overall) summaries.push_back(s);
  if (o.json)
    for (const Summary& s : summaries) std::printf("%s\n", summary_json(s).dump().c_str());
  else
    print_summaries(summaries);
  return 0;
}

}  // namespace

MIMIC_COMMAND(intersect, kName,
              "exact self-intersection of the posed skin over a clip, motion or session: folds, pairs "
              "between pieces, depth, creases",
              run);

}  // namespace mimic::app::cmd_intersect

#endif  // MIMIC_HAVE_EXACT
