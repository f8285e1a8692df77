// Shared by the body commands (mesh, compare): load the body model named on the command line
// (or the default), and find the pose a command asks for.
#pragma once

#include <optional>
#include <string>

#include "cli.h"
#include "mimic/avatar/body_model.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::app {

// --body FILE (a path or preset:NAME), or the built-in default body when `path` is empty.
Result<avatar::BodyModel> body_from_path(const std::string& path);

struct PoseRequest {
  std::string description;  // what was asked for, for the report ("07_01.bvh frame 120" ...)
  rig::Pose pose;
  double load_ms = 0;  // reading and retargeting the clip
};

// --bvh CLIP --frame N [--scale M] | --motion NAME --time S | --pose zero|rest.
struct PoseOptions {
  std::string bvh, motion, pose;
  long frame = -1;   // -1: not given
  double scale = 0;  // metres per BVH unit; 0: the CMU unit
  double time_s = 0;
  std::string set;  // --set DOF=RAD,...: then these DOFs, whatever the pose came from
};

// Declares the pose options on a command (ranges, choices and exclusions with them).
void add_pose_options(CLI::App& app, PoseOptions& o);

// The pose the options ask for, for `skeleton`. Errors name the option at fault; a request that
// does not make sense is Errc::invalid_argument (a usage error), a clip that does not load is not.
Result<PoseRequest> pose_from(const PoseOptions& o, const rig::Skeleton& skeleton);

}  // namespace mimic::app
