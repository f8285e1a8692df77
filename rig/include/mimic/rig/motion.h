// Motion sources: anything that yields a Pose of a skeleton at a time. The built-in procedural
// motions ("idle", "walk", "run") need no data files; BVH clips are retargeted onto Mimic's skeleton.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::rig {

class Motion {
 public:
  virtual ~Motion() = default;
  // The skeleton the poses are for (for a BVH clip: fitted to the performer's proportions).
  virtual const Skeleton& skeleton() const = 0;
  virtual double duration_s() const = 0;  // one cycle for looping motions
  virtual bool loops() const = 0;
  // Pose at time t_s (wrapped for looping motions, clamped otherwise). `out` must come from
  // skeleton().zero_pose() or an earlier sample(); never allocates then.
  virtual void sample(double t_s, Pose& out) const = 0;
  virtual std::string name() const = 0;
};

// "idle", "walk" or "run" on the given skeleton (a copy is kept).
Result<std::unique_ptr<Motion>> make_builtin_motion(std::string_view name, const Skeleton& skeleton);
std::vector<std::string> builtin_motion_names();

}  // namespace mimic::rig
