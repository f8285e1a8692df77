// One scene from the command line's sources, the same for `mimic run`, `mimic view` and the
// tests: every avatar's body, its source (service/source_registry.h) on that body's skeleton,
// its place in the room (--place, else side by side along X), a 6-DOF device moving it
// (--navigate), and, for the pipeline, its skin deformer.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "mimic/avatar/realtime_skin.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/scene.h"

namespace mimic::service {

// One `--source SPEC [--body FILE] [--calibration FILE] [--place X,Z[,DEG]] [--navigate SPEC]`
// group: the options after a --source belong to it.
struct SourceEntry {
  std::string spec = "sim:walk";
  std::string body;         // body model file or preset:NAME; empty: the default body
  std::string calibration;  // the wearer's calibration; empty: exact mounts or the standard layout
  std::string place;        // "X,Z" or "X,Z,HEADING_DEG"; empty: the row
  std::string navigate;     // a 6-DOF device spec (spaceball:, magellan:, spacemouse)
};

struct SceneSpec {
  std::vector<SourceEntry> sources;  // one per avatar; none: one sim:walk
  Room room;
  // Skin deformers for the pipeline (what `mimic run` serves as mesh frames); without, the
  // pipeline deforms by forward kinematics alone (a viewer that skins by itself).
  bool skins = true;
  int mesh_lod = 0;
  avatar::SkinMethod skin_method = avatar::SkinMethod::realtime;
};

struct SceneAvatar {
  std::string source;  // the spec as given
  std::unique_ptr<PoseFeed> feed;
  BodyAsset body;
  std::unique_ptr<Deformer> deformer;  // null without SceneSpec::skins
  Placement place;                     // where it starts
  bool in_row = true;                  // placed by the row (no --place, --navigate, not an actor)
};

struct Scene {
  std::shared_ptr<SceneRoster> roster;
  std::vector<SceneAvatar> avatars;
  std::vector<std::string> notes;  // to tell the user: a source that opened with a problem
};

struct SceneError {
  bool usage = false;  // the command line is wrong (exit 2); otherwise a source or body failed (1)
  std::string message;
};

tl::expected<Scene, SceneError> build_scene(const SceneSpec& spec);

// Avatar `index` of `count` without --place: side by side along X, 1.5 m apart, the row
// centred on the origin, facing +Z.
Placement row_placement(size_t index, size_t count);
// "X,Z" or "X,Z,HEADING_DEG" (metres, degrees).
bool parse_place(const std::string& text, Placement& place);
// "WxD": the room's width (x) and depth (z) in metres, 2..100 each.
bool parse_room(const std::string& text, Room& room);

}  // namespace mimic::service
