// A relay inside a viewer's process: what lets open_scene_connection take "nats://HOST:PORT/SCENE".
// A Server on a loopback port, fed from the broker on its own thread; the client then speaks
// the ordinary protocol to it, so a viewer behaves the same whichever way it joined.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <thread>

#include "mimic/core/result.h"
#include "mimic/net/nats.h"
#include "mimic/net/server.h"

namespace mimic::net::nats_detail {

class EmbeddedRelay {
 public:
  static Result<std::shared_ptr<EmbeddedRelay>> start(std::string_view target, bool udp);
  ~EmbeddedRelay();
  std::string endpoint() const { return server_->endpoint(); }

 private:
  std::unique_ptr<Server> server_;
  std::unique_ptr<NatsSceneFeed> feed_;
  std::thread thread_;
};

}  // namespace mimic::net::nats_detail
