// Opens any 6-DOF input device named by a source spec (devices/source.h):
//   spaceball:PATH   serial Spaceball 2003/3003/4000 FLX
//                    (probe=S dead=S reset=S tscale=N rscale=N null=N baud=N)
//   magellan:PATH    serial Magellan / SpaceMouse (settle=S probe=S dead=S scale=N null=N)
//   spacemouse       the first 3Dconnexion USB device; spacemouse:HIDRAW_PATH a given one;
//                    vid=HEX&pid=HEX narrow the search
//   spacemouse:sim   a simulated USB device (vid/pid pick the model, default 046d:c626
//                    SpaceNavigator; seed=N)
// Sources come back unstarted. Fails with a clear error on a scheme that yields tracker samples
// instead (see open_source.h), a bad parameter, or a driver this build lacks.
#pragma once

#include <memory>

#include "mimic/core/result.h"
#include "mimic/devices/source.h"

namespace mimic::sim {

Result<std::unique_ptr<devices::InputSource>> open_input_source(const devices::SourceSpec& spec);

}  // namespace mimic::sim
