// Ctrl-C (SIGINT) and SIGTERM, and SIGPIPE when asked, end a command's loop cleanly: the handler
// only sets a flag that the loop polls, so logs are closed and devices stopped properly.
#pragma once

namespace mimic::app {

void install_stop_handler(bool stop_on_sigpipe = false);
bool stop_requested();
void clear_stop_request();

}  // namespace mimic::app
