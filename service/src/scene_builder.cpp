#include "mimic/service/scene_builder.h"

#include <cmath>
#include <cstdio>

#include "mimic/service/source_registry.h"
#include "mimic/solver/calibration.h"
#include "mimic/sim/open_input.h"

namespace mimic::service {
namespace {

tl::unexpected<SceneError> usage(std::string message) { return tl::unexpected(SceneError{true, std::move(message)}); }
tl::unexpected<SceneError> failed(std::string message) { return tl::unexpected(SceneError{false, std::move(message)}); }

// An actor starts where --place says, else spread over the room's back half, away from the
// participants' row; an x= in its own spec wins.
std::string actor_spec(const SourceEntry& entry, const Placement& place, const Room& room) {
  const std::string& spec = entry.spec;
  if (spec.find("x=") != std::string::npos) return spec;
  std::string out = spec;
  const float z_m = entry.place.empty() ? -0.4f * room.half_depth_m : place.position_m.z;
  out.append(spec.find('?') == std::string::npos ? "?" : "&").append("x=").append(std::to_string(place.position_m.x));
  out.append("&z=").append(std::to_string(z_m));
  return out;
}

// The device moving an avatar through the room (--navigate), or none.
tl::expected<std::unique_ptr<devices::InputSource>, SceneError> open_navigator(const std::string& text,
                                                                               NavigationOptions& options) {
  if (text.empty()) return nullptr;
  auto nav = parse_navigation(text);
  if (!nav) return usage("--navigate: " + nav.error().message);
  options = nav->options;
  auto input = sim::open_input_source(nav->device);
  if (!input) return usage("--navigate: " + input.error().message);
  return std::move(*input);
}

// Body, source, placement and skin of one avatar.
tl::expected<SceneAvatar, SceneError> build_avatar(const SceneSpec& spec, const SourceEntry& entry, size_t index,
                                                   size_t count, const std::shared_ptr<SceneRoster>& roster,
                                                   std::vector<std::string>& notes) {
  SceneAvatar out;
  out.source = entry.spec;
  out.place = row_placement(index, count);
  if (!entry.place.empty() && !parse_place(entry.place, out.place))
    return usage("--place must be X,Z[,HEADING_DEG] in metres, got '" + entry.place + "'");
  // The body first: its skeleton is the one the avatar's source is solved on. Without --body, a
  // calibration that names the wearer's body (calibrate --body-out) brings it.
  std::string body_path = entry.body;
  if (body_path.empty() && !entry.calibration.empty()) {
    auto cal = solver::load_calibration(entry.calibration);
    if (!cal) return failed(cal.error().what());
    body_path = solver::calibration_body_path(entry.calibration, *cal);
  }
  auto asset = load_body(body_path);
  if (!asset) return failed(asset.error().what());
  auto skeleton = rig::Skeleton::build(asset->model.skeleton);
  if (!skeleton) return failed("body model " + body_path + ": " + skeleton.error().what());
  const SourceScheme* scheme = find_source_scheme(entry.spec);
  const bool self_placed = scheme && scheme->self_placed;
  SourceRequest request{self_placed ? actor_spec(entry, out.place, spec.room) : entry.spec, entry.calibration,
                        &*skeleton, roster, static_cast<int>(index)};
  auto feed = open_source(request);
  // A spec that does not parse or asks for a value out of its range (sensors=7) is a usage error
  // (2), as record and calibrate say; a source that cannot be opened is not (1).
  if (!feed && (feed.error().code == Errc::invalid_argument || feed.error().code == Errc::out_of_range))
    return usage(feed.error().what());
  if (!feed) return failed(feed.error().what());
  // A source that opened with a problem (e.g. a replayed log with damage) says so up front:
  // otherwise it would play what it can and then fall silent without a word.
  if (const std::string problem = (*feed)->status().last_error; !problem.empty())
    notes.push_back("source " + entry.spec + ": " + problem);
  if (!self_placed) {
    NavigationOptions navigation;
    auto navigator = open_navigator(entry.navigate, navigation);
    if (!navigator) return tl::unexpected(navigator.error());
    *feed =
        place_in_scene(std::move(*feed), out.place, roster, static_cast<int>(index), std::move(*navigator), navigation);
  }
  out.in_row = !self_placed && entry.place.empty() && entry.navigate.empty();
  if (spec.skins) {
    auto deformer = make_skin_deformer(asset->model, (*feed)->skeleton(), spec.mesh_lod, spec.skin_method);
    if (!deformer)
      return failed("body model " + (body_path.empty() ? std::string("(default)") : body_path) +
                    " does not fit source " + entry.spec + ": " + deformer.error().what());
    out.deformer = std::move(*deformer);
  }
  out.feed = std::move(*feed);
  out.body = std::move(*asset);
  return out;
}

}  // namespace

Placement row_placement(size_t index, size_t count) {
  Placement p;
  p.position_m.x = (static_cast<float>(index) - 0.5f * static_cast<float>(count - 1)) * 1.5f;
  return p;
}

bool parse_place(const std::string& text, Placement& place) {
  float x = 0, z = 0, deg = 0;
  char extra = 0;
  const int n = std::sscanf(text.c_str(), "%f,%f,%f%c", &x, &z, &deg, &extra);
  if (n != 2 && n != 3) return false;
  if (!std::isfinite(x) || !std::isfinite(z) || !std::isfinite(deg)) return false;
  place.position_m = {x, 0.0f, z};
  place.heading_rad = deg * 3.14159265f / 180.0f;
  return true;
}

bool parse_room(const std::string& text, Room& room) {
  float w = 0, d = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%f%c%f%c", &w, &x, &d, &extra) != 3 || x != 'x') return false;
  if (!(w >= 2 && w <= 100 && d >= 2 && d <= 100)) return false;
  room.half_width_m = 0.5f * w;
  room.half_depth_m = 0.5f * d;
  return true;
}

tl::expected<Scene, SceneError> build_scene(const SceneSpec& spec) {
  std::vector<SourceEntry> sources = spec.sources;
  if (sources.empty()) sources.emplace_back();
  // One scene: every avatar placed in the room, its place in the roster the actors read.
  Scene scene;
  scene.roster = std::make_shared<SceneRoster>(spec.room);
  for (size_t i = 0; i < sources.size(); ++i) scene.roster->join();
  for (size_t i = 0; i < sources.size(); ++i) {
    auto avatar = build_avatar(spec, sources[i], i, sources.size(), scene.roster, scene.notes);
    if (!avatar) return tl::unexpected(avatar.error());
    scene.avatars.push_back(std::move(*avatar));
  }
  return scene;
}

}  // namespace mimic::service
