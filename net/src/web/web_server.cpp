// The browser viewer's server: the page's files over HTTP, and WebSockets bridged one-to-one to
// TCP sessions of the scene server (web_server.h says why: a browser is a subscriber like any
// other, under the server's own limits and checks).
#include "mimic/net/web_server.h"

#include <utility>  // before Asio, which uses std::exchange without including it

#include <array>
#include <atomic>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <filesystem>
#include <map>
#include <sstream>
#include <thread>

#include "mimic/core/file.h"
#include "mimic/core/host_port.h"
#include "mimic/net/frame_codec.h"
#include "../tcp_listen.h"

namespace mimic::net {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

namespace {

struct PageFile {
  std::string name, type;
};
// The page's files: nothing else is served (no path reaches the file system).
const PageFile kPageFiles[] = {{"index.html", "text/html; charset=utf-8"},
                               {"viewer.js", "text/javascript; charset=utf-8"},
                               {"mimic_web.js", "text/javascript; charset=utf-8"},
                               {"mimic_web.wasm", "application/wasm"}};

std::chrono::steady_clock::duration seconds_of(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

struct WebServer::Impl {
  WebServerOptions opt;
  asio::io_context io{1};
  tcp::acceptor acceptor{io};
  tcp::endpoint scene;
  bool loopback = true;
  std::map<std::string, std::pair<std::string, std::string>> files;  // "/name" -> type, bytes
  std::thread thread;
  struct Counters {
    std::atomic<uint64_t> http_requests{0}, files_served{0}, not_found{0}, bad_requests{0}, ws_accepted{0},
        ws_refused{0}, ws_bad_messages{0}, ws_not_subscriber{0}, ws_open{0}, scene_unreachable{0}, bytes_to{0},
        bytes_from{0};
  } n;

  void accept();
  // Whether a WebSocket upgrade comes from this server's own page: a foreign Origin (another
  // site the browser has open) or a Host that is not this loopback server (DNS rebinding) is
  // refused.
  bool upgrade_allowed(const http::request<http::string_body>& req) const;
};

namespace {

// One WebSocket client and its TCP session with the scene server: browser messages go to the
// server as they are (the page writes protocol packets), the server's bytes go to the browser
// as binary messages. One write in flight each way: a browser that reads slowly stalls its own
// TCP session, where the server's latest-wins frame slots drop (and count) what it missed.
struct WsClient : std::enable_shared_from_this<WsClient> {
  WebServer::Impl& srv;
  websocket::stream<beast::tcp_stream> ws;
  tcp::socket scene;
  beast::flat_buffer in;
  std::array<uint8_t, 64 * 1024> down{};
  bool open = false, closed = false, hello_seen = false;

  WsClient(WebServer::Impl& s, tcp::socket sock) : srv(s), ws(std::move(sock)), scene(s.io) {}

  // `early` holds what the client sent after its upgrade request without waiting for the 101
  // (legal, though browsers never do it): the handshake then runs over the request's own bytes
  // followed by those, so that the first frame reaches the stream's reader instead of being lost
  // with the HTTP connection's buffer.
  void start(http::request<http::string_body> req, const std::string& early) {
    ws.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws.read_message_max(srv.opt.max_message_bytes);
    ws.binary(true);
    auto on_accept = [self = shared_from_this()](beast::error_code ec) {
      if (ec) {
        self->srv.n.ws_refused++;
        return;
      }
      self->open = true;
      self->srv.n.ws_accepted++;
      self->srv.n.ws_open++;
      self->scene.async_connect(self->srv.scene, [self](beast::error_code cec) {
        if (cec) {
          self->srv.n.scene_unreachable++;
          self->close();
          return;
        }
        boost::system::error_code nd;
        self->scene.set_option(tcp::no_delay(true), nd);
        self->read_browser();
        self->read_scene();
      });
    };
    if (early.empty()) {
      ws.async_accept(req, std::move(on_accept));
      return;
    }
    std::ostringstream raw;
    raw << req;
    // The stream's own read buffer holds what async_accept is given; more than fits is refused
    // (buffer_overflow) as any other failed handshake.
    ws.async_accept(asio::buffer(raw.str() + early), std::move(on_accept));
  }

  void read_browser() {
    ws.async_read(in, [self = shared_from_this()](beast::error_code ec, size_t n) {
      if (self->closed) return;
      if (ec) {
        if (ec == websocket::error::message_too_big || ec == websocket::condition::protocol_violation)
          self->srv.n.ws_bad_messages++;
        self->close();
        return;
      }
      if (!self->ws.got_binary()) {  // the protocol is binary: a text message is a broken client
        self->srv.n.ws_bad_messages++;
        self->close();
        return;
      }
      self->srv.n.bytes_from += n;
      if (!self->hello_seen && !self->subscriber_hello()) {
        self->srv.n.ws_not_subscriber++;
        self->close();
        return;
      }
      self->hello_seen = true;
      asio::async_write(self->scene, self->in.data(), [self](beast::error_code wec, size_t written) {
        self->in.consume(written);
        if (wec || self->closed) {
          self->close();
          return;
        }
        self->read_browser();
      });
    });
  }

  // The first message must be one whole HELLO of a subscriber. The scene server sees every
  // WebSocket come from loopback, where publishers need no secret: a browser must not publish
  // (and so reach --http from elsewhere to put avatars into the scene).
  bool subscriber_hello() const {
    const auto bytes = in.data();
    const std::span<const uint8_t> packet(static_cast<const uint8_t*>(bytes.data()), bytes.size());
    Header h;
    Hello hello;
    return decode_header(packet, h) == Reject::ok && h.type == MsgType::hello &&
           packet.size() == kHeaderBytes + h.payload_bytes && decode_hello(packet, hello) == Reject::ok &&
           hello.role == Role::subscriber;
  }

  void read_scene() {
    scene.async_read_some(asio::buffer(down), [self = shared_from_this()](beast::error_code ec, size_t n) {
      if (self->closed) return;
      if (ec) {  // the server ended the session (after its REJECT, which was forwarded)
        self->close();
        return;
      }
      self->srv.n.bytes_to += n;
      self->ws.async_write(asio::buffer(self->down.data(), n), [self](beast::error_code wec, size_t) {
        if (wec || self->closed) {
          self->close();
          return;
        }
        self->read_scene();
      });
    });
  }

  void close() {
    if (closed) return;
    closed = true;
    if (open) srv.n.ws_open--;
    boost::system::error_code ec;
    scene.close(ec);
    beast::get_lowest_layer(ws).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws).socket().close(ec);
  }
};

// One HTTP request: a page file, or the upgrade to a WebSocket (path /scene).
struct HttpConn : std::enable_shared_from_this<HttpConn> {
  WebServer::Impl& srv;
  beast::tcp_stream stream;
  beast::flat_buffer buf;
  http::request_parser<http::string_body> parser;
  http::response<http::string_body> res;

  HttpConn(WebServer::Impl& s, tcp::socket sock) : srv(s), stream(std::move(sock)) {
    parser.header_limit(8 * 1024);
    parser.body_limit(1024);
  }

  void start() {
    stream.expires_after(seconds_of(srv.opt.request_timeout_s));
    http::async_read(stream, buf, parser, [self = shared_from_this()](beast::error_code ec, size_t) {
      if (ec) {
        // A connection closed before sending anything is not a bad request (e.g. a port probe).
        if (ec != http::error::end_of_stream) self->srv.n.bad_requests++;
        return;
      }
      self->srv.n.http_requests++;
      self->on_request();
    });
  }

  void on_request() {
    http::request<http::string_body> req = parser.release();
    if (websocket::is_upgrade(req)) {
      if (req.target() != "/scene" || !srv.upgrade_allowed(req) || srv.n.ws_open >= srv.opt.max_clients) {
        srv.n.ws_refused++;
        respond(req, http::status::forbidden, "text/plain", "WebSocket refused\n");
        return;
      }
      stream.expires_never();
      std::make_shared<WsClient>(srv, stream.release_socket())
          ->start(std::move(req), beast::buffers_to_string(buf.data()));
      return;
    }
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      srv.n.bad_requests++;
      respond(req, http::status::method_not_allowed, "text/plain", "GET only\n");
      return;
    }
    std::string target(req.target());
    target = target.substr(0, target.find('?'));
    if (target == "/") target = "/index.html";
    const auto it = srv.files.find(target);
    if (it == srv.files.end()) {
      srv.n.not_found++;
      respond(req, http::status::not_found, "text/plain", "not found\n");
      return;
    }
    srv.n.files_served++;
    respond(req, http::status::ok, it->second.first, it->second.second);
  }

  void respond(const http::request<http::string_body>& req, http::status status, const std::string& type,
               const std::string& body) {
    res = http::response<http::string_body>(status, req.version());
    res.set(http::field::server, "mimic");
    res.set(http::field::content_type, type);
    res.set(http::field::cache_control, "no-cache");
    res.set("X-Content-Type-Options", "nosniff");
    if (req.method() != http::verb::head) res.body() = body;
    res.content_length(body.size());
    res.keep_alive(false);
    http::async_write(stream, res, [self = shared_from_this()](beast::error_code, size_t) {
      beast::error_code ec;
      self->stream.socket().shutdown(tcp::socket::shutdown_send, ec);
    });
  }
};

}  // namespace

void WebServer::Impl::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket sock) {
    if (!acceptor.is_open()) return;
    if (!ec) std::make_shared<HttpConn>(*this, std::move(sock))->start();
    accept();
  });
}

bool WebServer::Impl::upgrade_allowed(const http::request<http::string_body>& req) const {
  const std::string host(req[http::field::host]);
  if (loopback) {
    const std::string name = host.substr(0, host.rfind(':'));
    if (name != "127.0.0.1" && name != "localhost" && name != "[::1]") return false;
  }
  const auto origin = req[http::field::origin];
  return origin.empty() || origin == "http://" + host;
}

Result<std::unique_ptr<WebServer>> WebServer::create(const WebServerOptions& options) {
  auto hp = split_host_port(options.listen);
  if (!hp) return tl::unexpected(hp.error());
  auto scene_hp = split_host_port(options.scene);
  if (!scene_hp) return tl::unexpected(scene_hp.error());
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  for (const PageFile& f : kPageFiles) {
    auto bytes = read_file(options.root + "/" + f.name);
    if (bytes) impl->files["/" + f.name] = {f.type, std::move(*bytes)};
  }
  if (!impl->files.count("/index.html"))
    return fail(Errc::not_found, "the browser page's files are not in '" + options.root + "'");
  boost::system::error_code ec;
  const std::string host = hp->host == "localhost" ? "127.0.0.1" : hp->host;
  const auto addr = asio::ip::make_address(host, ec);
  if (ec) return fail(Errc::invalid_argument, "bad --http address '" + hp->host + "': " + ec.message());
  impl->loopback = addr.is_loopback();
  const std::string scene_host = scene_hp->host == "localhost" ? "127.0.0.1" : scene_hp->host;
  const auto scene_addr = asio::ip::make_address(scene_host, ec);
  if (ec) return fail(Errc::invalid_argument, "bad scene address '" + scene_hp->host + "'");
  impl->scene = tcp::endpoint(scene_addr, scene_hp->port);
  const tcp::endpoint ep(addr, hp->port);
  ec = detail::listen_tcp(impl->acceptor, ep);
  if (ec) return fail(Errc::io_error, "cannot listen on " + options.listen + ": " + ec.message());
  impl->accept();
  Impl* raw = impl.get();
  impl->thread = std::thread([raw] { raw->io.run(); });
  return std::unique_ptr<WebServer>(new WebServer(std::move(impl)));
}

WebServer::WebServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

WebServer::~WebServer() {
  if (!impl_) return;
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

uint16_t WebServer::port() const { return impl_->acceptor.local_endpoint().port(); }

std::string WebServer::endpoint() const {
  const auto ep = impl_->acceptor.local_endpoint();
  return ep.address().to_string() + ":" + std::to_string(ep.port());
}

bool WebServer::has_skin() const {
  return impl_->files.count("/mimic_web.wasm") && impl_->files.count("/mimic_web.js");
}

WebServerStats WebServer::stats() const {
  const auto& c = impl_->n;
  WebServerStats s;
  s.http_requests = c.http_requests;
  s.files_served = c.files_served;
  s.not_found = c.not_found;
  s.bad_requests = c.bad_requests;
  s.ws_accepted = c.ws_accepted;
  s.ws_refused = c.ws_refused;
  s.ws_bad_messages = c.ws_bad_messages;
  s.ws_not_subscriber = c.ws_not_subscriber;
  s.ws_open = c.ws_open;
  s.scene_unreachable = c.scene_unreachable;
  s.bytes_to_browsers = c.bytes_to;
  s.bytes_from_browsers = c.bytes_from;
  return s;
}

std::string default_web_root(const std::string& exe_path) {
  std::error_code ec;
  const auto exe = std::filesystem::weakly_canonical(exe_path, ec);
  if (!ec) {
    const auto beside = exe.parent_path().parent_path() / "web";
    if (std::filesystem::exists(beside / "index.html", ec)) return beside.string();
  }
#ifdef MIMIC_WEB_ROOT
  return MIMIC_WEB_ROOT;
#else
  return "web";
#endif
}

}  // namespace mimic::net
