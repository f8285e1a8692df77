// Session tokens that cannot be predicted, and the limits that keep idle or hostile connections
// from filling the server: handshake deadline, idle timeout, per-address limit.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "net_test_support.h"

namespace mimic::net::session_limits_test {
namespace {

using namespace mimic::net::test;

// ---- an attack on std::mt19937_64: 312 outputs give its state, and so every later output ----

uint64_t untemper(uint64_t y) {
  y ^= y >> 43;
  y ^= (y << 37) & 0xFFF7EEE000000000ull;
  uint64_t x = y;
  for (int i = 0; i < 4; ++i) x = y ^ ((x << 17) & 0x71D67FFFEDA60000ull);
  y = x;
  for (int i = 0; i < 3; ++i) x = y ^ ((x >> 29) & 0x5555555555555555ull);
  return x;
}

uint64_t temper(uint64_t y) {
  y ^= (y >> 29) & 0x5555555555555555ull;
  y ^= (y << 17) & 0x71D67FFFEDA60000ull;
  y ^= (y << 37) & 0xFFF7EEE000000000ull;
  y ^= y >> 43;
  return y;
}

// The next `count` outputs of an mt19937_64 whose last 312 outputs were `seen` (in order).
std::vector<uint64_t> predict_mt19937_64(const std::vector<uint64_t>& seen, size_t count) {
  std::vector<uint64_t> x;
  for (size_t i = seen.size() - 312; i < seen.size(); ++i) x.push_back(untemper(seen[i]));
  std::vector<uint64_t> next;
  for (size_t k = 0; k < count; ++k) {
    const size_t j = x.size() - 312;
    const uint64_t y = (x[j] & 0xFFFFFFFF80000000ull) | (x[j + 1] & 0x7FFFFFFFull);
    x.push_back(x[j + 156] ^ (y >> 1) ^ ((y & 1) ? 0xB5026F5AA96619E9ull : 0));
    next.push_back(temper(x.back()));
  }
  return next;
}

std::array<uint64_t, 2> halves(const SessionToken& t) {
  std::array<uint64_t, 2> h{};
  std::memcpy(h.data(), t.bytes.data(), kTokenBytes);
  return h;
}

TEST(SessionTokens, TheMersenneTwisterAttackWorksOnItsOwnGenerator) {
  // The attack itself, against the generator tokens once came from: it must succeed here, or
  // its failure against the server below would prove nothing.
  std::mt19937_64 rng(std::random_device{}());
  std::vector<uint64_t> seen(400);
  for (auto& v : seen) v = rng();
  const auto predicted = predict_mt19937_64(seen, 8);
  for (uint64_t p : predicted) EXPECT_EQ(p, rng());
}

// 320 handshakes' tokens, read as any stream of 64-bit outputs, do not predict the next token.
TEST(SessionTokens, HandshakesDoNotRevealTheNextToken) {
  ServerOptions o;
  o.max_sessions_per_address = 1000;
  ServerThread st(o);
  std::vector<SessionToken> tokens;
  for (int i = 0; i < 320; ++i) {
    RawPeer peer(st.port());
    ASSERT_TRUE(peer.send(hello_packet(Role::subscriber)));
    Welcome w;
    ASSERT_EQ(decode_welcome(read_packet(peer), w), Reject::ok) << "handshake " << i;
    tokens.push_back(w.session_token);
  }
  std::vector<uint64_t> both, lows, highs;
  for (size_t i = 0; i + 1 < tokens.size(); ++i) {
    const auto h = halves(tokens[i]);
    both.push_back(h[0]);
    both.push_back(h[1]);
    lows.push_back(h[0]);
    highs.push_back(h[1]);
  }
  const auto next = halves(tokens.back());
  const auto p_both = predict_mt19937_64(both, 2);
  EXPECT_FALSE(p_both[0] == next[0] && p_both[1] == next[1]);
  EXPECT_NE(predict_mt19937_64(lows, 1)[0], next[0]);
  EXPECT_NE(predict_mt19937_64(highs, 1)[0], next[1]);
  // 128 bits each, all different, about half of the bits set.
  size_t ones = 0;
  for (size_t i = 0; i < tokens.size(); ++i) {
    EXPECT_FALSE(tokens[i].empty());
    for (size_t j = 0; j < i; ++j) EXPECT_FALSE(tokens[i] == tokens[j]);
    for (uint8_t b : tokens[i].bytes) ones += size_t(std::popcount(b));
  }
  const double fraction = double(ones) / double(tokens.size() * 128);
  EXPECT_NEAR(fraction, 0.5, 0.02);
}

TEST(SessionTokens, EqualityLooksAtEveryByte) {
  SessionToken a, b;
  a.bytes.fill(7);
  b.bytes.fill(7);
  EXPECT_TRUE(a == b);
  for (size_t i = 0; i < kTokenBytes; ++i) {
    SessionToken c = a;
    c.bytes[i] ^= 0x80;
    EXPECT_FALSE(a == c) << "byte " << i;
  }
  EXPECT_TRUE(SessionToken{}.empty());
  EXPECT_FALSE(a.empty());
}

// 300 connections from one address that say HELLO and then nothing: the per-address limit
// refuses all but 64 at once, the idle timeout closes those, and in the meantime another
// address is still served. Memory and time both stay bounded.
TEST(SessionLimits, IdleFloodFromOneAddressIsBoundedInCountAndTime) {
  ServerOptions o;
  o.max_sessions_per_address = 64;
  o.idle_timeout_s = 0.5;
  o.housekeeping_period_ms = 50;
  ServerThread st(o);
  std::vector<std::unique_ptr<RawPeer>> flood;
  for (int i = 0; i < 300; ++i) {
    flood.push_back(std::make_unique<RawPeer>(st.port()));
    flood.back()->send(hello_packet(Role::subscriber));
  }
  ASSERT_TRUE(pump(
      {}, [&] { return st.stats().sessions_refused_per_address == 300 - 64; }, 5.0))
      << st.stats().sessions_refused_per_address;
  EXPECT_LE(st.stats().sessions_open, 64u);
  // Another host is not locked out.
  RawPeer other(st.port(), 0, "127.0.0.2");
  ASSERT_TRUE(other.send(hello_packet(Role::subscriber)));
  Welcome w;
  EXPECT_EQ(decode_welcome(read_packet(other), w), Reject::ok);
  // Every idle session is gone well within a second of its timeout.
  const auto t0 = Clock::now();
  ASSERT_TRUE(pump(
      {}, [&] { return st.stats().sessions_open == 0; }, 5.0))
      << st.stats().sessions_open;
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 2.0);
  const ServerStats s = st.stats();
  EXPECT_EQ(s.sessions_timed_out, 65u);
  EXPECT_EQ(s.rejected[size_t(Reject::too_many_sessions)], 300u - 64u);
  // The address has its slots back.
  RawPeer again(st.port());
  ASSERT_TRUE(again.send(hello_packet(Role::subscriber)));
  EXPECT_EQ(decode_welcome(read_packet(again), w), Reject::ok);
}

// A quiet client is not idle: it sends PING while it has nothing else to say.
TEST(SessionLimits, AQuietClientStaysConnected) {
  ServerOptions o;
  o.idle_timeout_s = 3.0;
  o.housekeeping_period_ms = 50;
  ServerThread st(o);
  ClientOptions c;
  c.connect = st.endpoint();
  auto sub = Client::connect(c);
  ASSERT_TRUE(sub);
  RawPeer silent(st.port());
  ASSERT_TRUE(silent.send(hello_packet(Role::subscriber)));
  pump_for({sub->get()}, 4.0);
  EXPECT_TRUE(silent.wait_closed(1.0));
  EXPECT_TRUE((*sub)->connected());
  EXPECT_TRUE((*sub)->poll());
  EXPECT_EQ(st.stats().sessions_timed_out, 1u);
  EXPECT_EQ(st.stats().subscribers, 1u);
}

// The handshake deadline holds however slowly the HELLO trickles in.
TEST(SessionLimits, ASlowHelloMissesTheHandshakeDeadline) {
  ServerOptions o;
  o.hello_timeout_s = 0.4;
  ServerThread st(o);
  RawPeer slow(st.port());
  const Bytes hello = hello_packet(Role::subscriber);
  const auto t0 = Clock::now();
  for (size_t i = 0; i + 1 < hello.size() && !slow.closed(); ++i) {
    slow.send(&hello[i], 1);
    (void)slow.read(0.05);
  }
  EXPECT_TRUE(slow.wait_closed(2.0));
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 2.0);
  EXPECT_EQ(st.stats().sessions_timed_out, 1u);
}

// "localhost" is the loopback address: accepted without a secret, and served on 127.0.0.1.
TEST(SessionLimits, LocalhostListensOnLoopback) {
  ServerOptions o;
  o.listen = "localhost:0";
  auto s = Server::create(o);
  ASSERT_TRUE(s) << s.error().what();
  EXPECT_EQ((*s)->endpoint().rfind("127.0.0.1:", 0), 0u) << (*s)->endpoint();
}

}  // namespace
}  // namespace mimic::net::session_limits_test
