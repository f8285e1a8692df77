// Shared by the body commands (mesh, compare): load the body model named on the command line
// (or the default), and find the pose a command asks for.
#pragma once

#include <optional>
#include <string>

#include "command.h"
#include "mimic/avatar/body_model.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::app {

// --body FILE, or the built-in default body when absent.
Result<avatar::BodyModel> body_from_args(const Args& args);

struct PoseRequest {
  std::string description;  // what was asked for, for the report ("07_01.bvh frame 120" ...)
  rig::Pose pose;
  double load_ms = 0;       // reading and retargeting the clip
};

// --bvh CLIP --frame N [--scale M] | --motion NAME --time S | --pose zero|rest, for `skeleton`.
// Errors name the option at fault.
Result<PoseRequest> pose_from_args(const Args& args, const rig::Skeleton& skeleton);

}  // namespace mimic::app
