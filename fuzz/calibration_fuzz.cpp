// libFuzzer entry point for calibration files (`mimic-calibration` JSON): any bytes must either
// load into a calibration whose skeleton builds and whose solver model can be made, or fail
// with a message naming what is wrong. A loaded calibration must survive being written again.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "mimic/solver/calibration.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mimic::solver;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto cal = calibration_from_json(text);
  if (!cal) {
    if (cal.error().message.empty()) std::abort();
    return 0;
  }
  if (!mimic::rig::Skeleton::build(cal->skeleton)) std::abort();
  (void)make_solver_model(*cal);  // may refuse (a skeleton without Mimic's chains), never crash
  auto again = calibration_from_json(calibration_to_json(*cal));
  if (!again || again->sensors.size() != cal->sensors.size() ||
      again->skeleton.joints.size() != cal->skeleton.joints.size())
    std::abort();
  return 0;
}
