// libFuzzer entry point for body model files (`mimic-body` JSON), which also arrive from
// publishers over the network: any bytes must either load into a model that validates, or fail
// with a message naming the JSON path. A loaded model must survive being written again.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "mimic/avatar/body_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mimic::avatar;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto model = body_model_from_json(text, "fuzz");
  if (!model) {
    if (model.error().message.empty()) std::abort();
    return 0;
  }
  auto again = body_model_from_json(to_json(*model, false), "fuzz-again");
  if (!again || again->primitives.size() != model->primitives.size()) std::abort();
  return 0;
}
