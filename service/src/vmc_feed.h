// A `vmc:[HOST:]PORT` source: VMC performer data received on UDP becomes the avatar's pose
// directly (no solver: the sender has solved its body already), retargeted onto Mimic's
// skeleton bone by bone (net/vmc_receive.h).
#pragma once

#include <memory>

#include "mimic/core/result.h"
#include "mimic/devices/source.h"
#include "mimic/service/pipeline.h"

namespace mimic::service {

Result<std::unique_ptr<PoseFeed>> open_vmc_feed(const devices::SourceSpec& spec, const rig::Skeleton* body);

}  // namespace mimic::service
