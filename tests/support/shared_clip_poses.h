// Every `every`-th frame of every shared clip (each clip's opening T-pose included), retargeted
// onto a body's skeleton: the sweep the skin's tests pose a body through.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>

#include "mimic/rig/bvh.h"
#include "mimic/rig/retarget.h"
#include "test_data.h"

namespace mimic::test {

// fn(const rig::Pose&) per frame; a clip that does not load or retarget fails the test and is skipped.
template <class Fn>
void for_each_shared_clip_pose(const rig::Skeleton& skeleton, size_t every, Fn&& fn) {
  for (const char* id : kShared_clips) {
    auto clip = rig::load_bvh(clip_path(id));
    EXPECT_TRUE(clip) << clip.error().what();
    if (!clip) continue;
    auto r = rig::retarget_bvh(*clip);
    EXPECT_TRUE(r) << r.error().what();
    if (!r) continue;
    for (size_t f = 0; f < r->poses.size(); f += every) fn(rig::transfer_pose(r->skeleton, r->poses[f], skeleton));
  }
}

// A count a frame (folds, pairs) over a sweep: frames, total, the worst frame.
struct FrameTally {
  size_t frames = 0, total = 0, worst = 0;
  double mean() const { return frames ? double(total) / double(frames) : 0.0; }
  void add(size_t count) { ++frames, total += count, worst = std::max(worst, count); }
};

}  // namespace mimic::test
