// The sources an avatar can follow, one table of schemes (`--source SCHEME:TARGET?KEY=VALUE`):
// how a spec of each is checked (without opening anything: a spec that does not parse is a
// usage error) and how it becomes a PoseFeed. `mimic run`, `mimic view` and the tests reach
// sources only through this table (via build_scene, service/scene_builder.h), so a scheme
// added here is taken by every command at once.
//
// Kinds: trackers (sim, bvh, replay, flock) send samples the body solver turns into poses;
// vmc brings poses a sender has solved; actors walk the room by themselves. VRPN and OSC
// trackers come next: one row each, opening through sim::open_sensor_source (samples) or a
// PoseFeed of their own (poses), as vmc does.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/scene.h"

namespace mimic::service {

// What opening one avatar's source needs besides the spec.
struct SourceRequest {
  std::string text;                     // the spec as given
  std::string calibration;              // the wearer's calibration (mimic calibrate), or empty
  const rig::Skeleton* body = nullptr;  // the avatar's body skeleton (solved on, walked with)
  std::shared_ptr<SceneRoster> roster;  // where every avatar stands (actors read it)
  int slot = 0;                         // this avatar's slot in the roster
};

struct SourceScheme {
  const char* scheme;
  const char* example;  // for usage text and errors
  // The feed places itself in the room (actors); otherwise the scene places it (--place).
  bool self_placed;
  // Checks the spec without opening anything; an invalid_argument error is a usage error.
  Status (*check)(const std::string& text);
  Result<std::unique_ptr<PoseFeed>> (*open)(const SourceRequest& request);
};

std::span<const SourceScheme> source_schemes();
// The row of the spec's scheme (the text up to ':' or '?'), or null.
const SourceScheme* find_source_scheme(std::string_view text);
// "sim, bvh, replay, flock, vmc, actor".
std::string source_scheme_list();

// Checks `request.text` against its row and opens it. A scheme the table lacks fails with
// invalid_argument naming the known ones (a device the spec parser knows but that gives no
// poses, such as a spaceball, fails with its own reason).
Result<std::unique_ptr<PoseFeed>> open_source(const SourceRequest& request);

}  // namespace mimic::service
