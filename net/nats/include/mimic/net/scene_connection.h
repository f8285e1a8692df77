// A viewer's way into a scene, whichever way the scene is offered: HOST:PORT (a Mimic server or
// relay) is Client::connect; a scene on a NATS broker, nats://HOST:PORT[,nats://HOST:PORT...][/SCENE],
// is served by a relay inside this process (a Server on a loopback port fed from the broker on
// its own thread) that the client then joins with the ordinary protocol, so a viewer behaves
// the same whichever way it joined. The client holds that relay and stops it when destroyed.
// Broker credentials come from the environment (nats_credentials_from_env).
#pragma once

#include <memory>

#include "mimic/core/result.h"
#include "mimic/net/client.h"

namespace mimic::net {

// Subscribers only: publishing into a broker's scene is a NatsPublisher (mimic run --nats).
Result<std::unique_ptr<Client>> open_scene_connection(const ClientOptions& options);

}  // namespace mimic::net
