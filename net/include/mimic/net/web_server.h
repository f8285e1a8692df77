// The browser viewer's server (`mimic run --http`): serves the page (index.html, viewer.js and
// the WebAssembly skin, from a folder of files loaded once at start) and carries the scene
// protocol over WebSockets. A WebSocket client is a subscriber of the scene server like any
// other: each one gets its own TCP session to that server, and the page speaks the protocol
// itself (HELLO, then body models and the lean pose stream), so every limit and check of the
// server applies to it unchanged (hostile packets are refused and counted in ServerStats, the
// session ends). What is the WebSocket's own — bad HTTP, refused upgrades, text or oversized
// messages, foreign origins — is refused here and counted in WebServerStats, and so is a first
// message that is not a subscriber's HELLO: over the WebSocket nobody publishes.
//
// Threading: the server runs on a thread of its own; stats() may be read from any thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "mimic/core/result.h"

namespace mimic::net {

struct WebServerOptions {
  std::string listen = "127.0.0.1:0";  // ADDR:PORT; port 0 picks a free port
  std::string scene;                   // HOST:PORT of the scene server the WebSockets join
  std::string root;                    // folder holding the page's files
  size_t max_clients = 64;             // WebSocket clients at once (each is a scene session)
  // A browser sends what a subscriber sends (HELLO, KEY_REQUEST, PING, BYE): small packets.
  size_t max_message_bytes = 512;
  double request_timeout_s = 5.0;  // the HTTP request (and upgrade) must be complete in time
};

struct WebServerStats {
  uint64_t http_requests = 0;      // complete requests read
  uint64_t files_served = 0;       // 200 responses with a file
  uint64_t not_found = 0;          // 404: not one of the page's files (or the file is missing)
  uint64_t bad_requests = 0;       // unreadable HTTP, methods other than GET/HEAD, timeouts
  uint64_t ws_accepted = 0;        // WebSocket handshakes completed
  uint64_t ws_refused = 0;         // upgrades refused: bad handshake, foreign Origin, over max_clients
  uint64_t ws_bad_messages = 0;    // text, oversized or malformed WebSocket frames (the client is closed)
  uint64_t ws_not_subscriber = 0;  // first message not a subscriber's HELLO (a browser may not publish)
  uint64_t ws_open = 0;            // WebSocket clients now
  uint64_t scene_unreachable = 0;  // WebSockets closed because the scene server refused the connection
  uint64_t bytes_to_browsers = 0;
  uint64_t bytes_from_browsers = 0;
};

class WebServer {
 public:
  static Result<std::unique_ptr<WebServer>> create(const WebServerOptions& options);
  ~WebServer();  // stops the thread and closes every connection
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  uint16_t port() const;
  std::string endpoint() const;  // "127.0.0.1:8080"
  bool has_skin() const;         // the WebAssembly skin was found in the root folder
  WebServerStats stats() const;

  struct Impl;

 private:
  explicit WebServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The folder of the page's files next to a `mimic` executable at `exe_path` (../web from its
// bin folder), else the one the build wrote them to.
std::string default_web_root(const std::string& exe_path);

}  // namespace mimic::net
