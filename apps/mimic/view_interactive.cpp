#if MIMIC_HAVE_RENDER  // built with MIMIC_WITH_VIEWER
#include "view_interactive.h"

namespace mimic::app {

int run_interactive(Args&, const ViewOptions&) { return failure("view", "the interactive viewer is not built yet"); }

}  // namespace mimic::app

#endif  // MIMIC_HAVE_RENDER
