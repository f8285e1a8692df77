// How `mimic subscribe` and `mimic view --connect` join a scene: HOST:PORT of a server or relay,
// or, when the program is built with the broker transport (mimic::nats), a scene on a NATS
// broker through a relay inside this process (open_scene_connection).
#pragma once

#include <memory>

#include "mimic/core/result.h"
#include "mimic/net/client.h"
#if MIMIC_HAVE_NATS
#include "mimic/net/scene_connection.h"
#endif

namespace mimic::app {

inline Result<std::unique_ptr<net::Client>> connect_scene(const net::ClientOptions& options) {
#if MIMIC_HAVE_NATS
  return net::open_scene_connection(options);
#else
  if (options.connect.starts_with("nats://") || options.connect.starts_with("tls://"))
    return fail(Errc::unsupported, "this build has no NATS support (configure with -DMIMIC_WITH_NATS=ON)");
  return net::Client::connect(options);
#endif
}

}  // namespace mimic::app
