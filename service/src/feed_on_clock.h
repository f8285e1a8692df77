// open_feed on a clock the caller steps (offline solves of recorded sessions): the replayed
// samples are released as that clock advances instead of the host's.
#pragma once

#include <memory>
#include <string>

#include "mimic/service/pipeline.h"
#include "mimic/core/clock.h"

namespace mimic::service {

Result<std::unique_ptr<PoseFeed>> open_feed_on_clock(const std::string& spec_text, const std::string& calibration_path,
                                                     const rig::Skeleton* body, std::shared_ptr<const Clock> clock);

}  // namespace mimic::service
