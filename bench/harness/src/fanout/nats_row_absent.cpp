// The fan-out bench's broker row in a build without the NATS transport (MIMIC_WITH_NATS=OFF:
// no mimic::nats target; CMake compiles this file instead of nats_row.cpp).
#include "fanout/swarm.h"
#include "mimic/bench/loopback_bench.h"

namespace mimic::bench {

Status fanout_nats_available() {
  return fail(Errc::unsupported, "this build has no NATS transport (MIMIC_WITH_NATS=OFF)");
}

namespace fanout {
Result<FanoutCapacity> measure_nats(const FanoutOptions&) { return tl::unexpected(fanout_nats_available().error()); }
}  // namespace fanout

}  // namespace mimic::bench
