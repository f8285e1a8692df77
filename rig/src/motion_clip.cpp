// A Motion that plays a retargeted BVH clip (no looping, linear interpolation between frames).
#include <algorithm>
#include <cmath>

#include "mimic/rig/retarget.h"

namespace mimic::rig {

namespace {

class ClipMotion final : public Motion {
 public:
  explicit ClipMotion(RetargetedClip clip) : clip_(std::move(clip)) {}

  const Skeleton& skeleton() const override { return clip_.skeleton; }
  double duration_s() const override {
    return clip_.poses.empty() ? 0.0 : (static_cast<double>(clip_.poses.size()) - 1) * clip_.frame_time_s;
  }
  bool loops() const override { return false; }
  std::string name() const override { return clip_.source_name; }

  void sample(double t_s, Pose& out) const override {
    const int n = static_cast<int>(clip_.poses.size());
    if (n == 0) return;
    double f = std::isfinite(t_s) ? t_s / clip_.frame_time_s : 0.0;
    f = std::clamp(f, 0.0, static_cast<double>(n - 1));
    const int i = std::min(static_cast<int>(f), n - 1);
    const int k = std::min(i + 1, n - 1);
    const float a = static_cast<float>(f - i);
    const Pose& p = clip_.poses[i];
    const Pose& q = clip_.poses[k];
    out.dof_rad.resize(p.dof_rad.size());  // no-op (no allocation) once sized
    for (size_t d = 0; d < p.dof_rad.size(); ++d) out.dof_rad[d] = p.dof_rad[d] + a * (q.dof_rad[d] - p.dof_rad[d]);
    out.root_position_m = p.root_position_m + a * (q.root_position_m - p.root_position_m);
    out.root_orientation = glm::slerp(p.root_orientation, q.root_orientation, a);  // shortest path
  }

 private:
  RetargetedClip clip_;
};

}  // namespace

std::unique_ptr<Motion> make_clip_motion(RetargetedClip clip) { return std::make_unique<ClipMotion>(std::move(clip)); }

Result<std::unique_ptr<Motion>> load_bvh_motion(const std::string& path, const BvhMotionOptions& options) {
  auto clip = load_bvh(path, BvhParseOptions{options.metres_per_unit});
  if (!clip) return tl::unexpected(clip.error());
  auto retargeted = retarget_bvh(*clip);
  if (!retargeted) return tl::unexpected(retargeted.error());
  if (options.body) {
    for (Pose& p : retargeted->poses) p = transfer_pose(retargeted->skeleton, p, *options.body);
    retargeted->skeleton = *options.body;
  }
  return make_clip_motion(std::move(*retargeted));
}

}  // namespace mimic::rig
