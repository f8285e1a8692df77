// The browser viewer's WebSocket is a network input like any other: a raw TCP peer plays bad
// HTTP, refused upgrades, broken WebSocket frames and hostile protocol packets against a real
// `mimic run --http`, and every one is refused and counted (WebServerStats for what is the
// WebSocket's own, the scene server's rejected counters for the packets it carried), while a
// well-formed subscriber over the same WebSocket gets the scene.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "mimic/net/frame_codec.h"
#include "mimic_proc.h"
#include "web_support.h"

namespace web_socket_test {

using ::mimic::test::Proc;

// A TCP connection to HOST:PORT of the page's URL, with blocking writes and timed reads.
struct Peer {
  int fd = -1;
  explicit Peer(uint16_t port) {
    fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ~Peer() {
    if (fd >= 0) ::close(fd);
  }
  void send(const std::string& bytes) const { (void)!::write(fd, bytes.data(), bytes.size()); }
  // Appends what arrives within 100 ms; false once the peer has closed.
  bool read_some(std::string& got) const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) return true;
    char b[8192];
    const ssize_t n = ::read(fd, b, sizeof b);
    if (n <= 0) return false;
    got.append(b, size_t(n));
    return true;
  }
  // Everything that arrives until the peer closes or `timeout_s` passes.
  std::string read_all(double timeout_s = 10) const {
    std::string got;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end && read_some(got)) {}
    return got;
  }
  // Reads until `text` arrived (true) or the timeout.
  bool read_until(const std::string& text, std::string& got, double timeout_s = 10) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (got.find(text) == std::string::npos && std::chrono::steady_clock::now() < end && read_some(got)) {}
    return got.find(text) != std::string::npos;
  }
};

std::string upgrade(uint16_t port, const std::string& extra = "", const std::string& path = "/scene") {
  return "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
         "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\n" + extra + "\r\n";
}
const std::string kKey = "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n";

// A client frame (RFC 6455): FIN, the opcode, masked unless `masked` is false.
std::string frame(uint8_t opcode, const std::string& payload, bool masked = true) {
  std::string f(1, char(0x80 | opcode));
  const uint8_t m = masked ? 0x80 : 0;
  if (payload.size() < 126) {
    f += char(m | payload.size());
  } else {
    f += char(m | 126);
    f += char(payload.size() >> 8);
    f += char(payload.size() & 0xFF);
  }
  const std::array<char, 4> key = {0x12, 0x34, 0x56, 0x78};
  if (masked) f.append(key.data(), 4);
  for (size_t i = 0; i < payload.size(); ++i) f += masked ? char(payload[i] ^ key[i % 4]) : payload[i];
  return f;
}

std::string hello_packet(mimic::net::Role role = mimic::net::Role::subscriber) {
  mimic::net::Hello h;
  h.role = role;
  h.capabilities = mimic::net::kCapPose | mimic::net::kCapLeanPose;
  h.name = "test";
  std::array<uint8_t, 512> buf{};
  const size_t n = mimic::net::encode_hello(h, buf);
  return std::string(reinterpret_cast<const char*>(buf.data()), n);
}

uint16_t port_of(const std::string& url) {
  const size_t colon = url.rfind(':');
  return uint16_t(std::stoi(url.substr(colon + 1)));
}

TEST(BrowserWebSocket, RefusesAndCountsBadHandshakesAndHostileFrames) {
  Proc run({"run", "--quiet", "--json", "--listen", "127.0.0.1:0", "--no-udp", "--http", "127.0.0.1:0"});
  const std::string url = ::mimic::test::web::page_url(run.first_line(30));
  ASSERT_FALSE(url.empty()) << run.out() << run.err();
  const uint16_t port = port_of(url);
  std::string got;
  {  // Not HTTP at all: closed.
    Peer p(port);
    p.send("\x01\x02garbage\r\n\r\n");
    EXPECT_EQ(p.read_all(), "");
  }
  {  // An upgrade without its key: the handshake is refused (400).
    Peer p(port);
    p.send(upgrade(port));
    EXPECT_NE(p.read_all().find("HTTP/1.1 400"), std::string::npos);
  }
  {  // Another site's page asking for the scene (Origin): refused (403).
    Peer p(port);
    p.send(upgrade(port, kKey + "Origin: http://evil.example\r\n"));
    EXPECT_NE(p.read_all().find("HTTP/1.1 403"), std::string::npos);
  }
  {  // A file that is not the page's.
    Peer p(port);
    p.send("GET /../../etc/passwd HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    EXPECT_NE(p.read_all().find("HTTP/1.1 404"), std::string::npos);
  }
  // Accepted handshakes, then frames the WebSocket layer refuses: text, oversized, unmasked.
  for (const std::string& bad :
       {frame(0x1, "hello"), frame(0x2, std::string(600, 'M')), frame(0x2, hello_packet(), false)}) {
    Peer p(port);
    p.send(upgrade(port, kKey));
    ASSERT_TRUE(p.read_until("\r\n\r\n", got = "")) << got;
    EXPECT_NE(got.find("101 Switching Protocols"), std::string::npos) << got;
    p.send(bad);
    p.read_all(5);  // closed by the server
  }
  // First messages that are not a subscriber's HELLO: a publisher's (over the WebSocket nobody
  // publishes: the scene server sees it from loopback, where publishers need no secret), and
  // bytes that are no packet at all. Closed by the web server.
  for (const std::string& first :
       {hello_packet(mimic::net::Role::publisher), std::string("XX\x01\x00\x00\x00\x00\x00", 8)}) {
    Peer p(port);
    p.send(upgrade(port, kKey));
    ASSERT_TRUE(p.read_until("\r\n\r\n", got = ""));
    p.send(frame(0x2, first));
    p.read_all(5);
  }
  {  // A subscriber, then a packet with a bad magic byte: the scene server REJECTs and counts it.
    Peer p(port);
    p.send(upgrade(port, kKey));
    ASSERT_TRUE(p.read_until("\r\n\r\n", got = ""));
    p.send(frame(0x2, hello_packet()));
    p.send(frame(0x2, std::string("XX\x01\x00\x00\x00\x00\x00", 8)));
    p.read_all(5);
  }
  {  // A real subscriber over the WebSocket: WELCOME and the avatar's model arrive.
    Peer p(port);
    p.send(upgrade(port, kKey + "Origin: http://127.0.0.1:" + std::to_string(port) + "\r\n"));
    ASSERT_TRUE(p.read_until("\r\n\r\n", got = ""));
    p.send(frame(0x2, hello_packet()));
    EXPECT_TRUE(p.read_until("mimic-default", got, 20)) << "no body model over the WebSocket";
  }
  {  // A client that sends its first frame with the upgrade, before the 101: the frame is kept.
    Peer p(port);
    p.send(upgrade(port, kKey) + frame(0x2, hello_packet()));
    EXPECT_TRUE(p.read_until("mimic-default", got = "", 20)) << "the early HELLO was lost: " << got;
  }
  run.signal(SIGINT);
  ASSERT_EQ(run.wait(30), 0) << run.err();
  const std::string& out = run.out();
  auto j = nlohmann::json::parse(out.substr(out.rfind("\n{") + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << out;
  auto& h = j["http"];
  EXPECT_GE(h["bad_requests"].get<int>(), 1) << h.dump();
  EXPECT_EQ(h["ws_refused"].get<int>(), 2) << h.dump();
  EXPECT_EQ(h["not_found"].get<int>(), 1) << h.dump();
  EXPECT_EQ(h["ws_bad_messages"].get<int>(), 3) << h.dump();
  EXPECT_EQ(h["ws_not_subscriber"].get<int>(), 2) << h.dump();
  EXPECT_EQ(h["ws_accepted"].get<int>(), 8) << h.dump();
  EXPECT_EQ(j["server"]["rejected_by_reason"]["bad_magic"].get<int>(), 1) << j["server"].dump();
}

}  // namespace web_socket_test
