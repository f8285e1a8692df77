// Bare `mimic`, typed to see what the tool is: an overview and the commands, at once, with no
// server started (the server is `mimic run`).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "run_mimic.h"

namespace overview_test {

namespace {

TEST(Overview, BareMimicPrintsTheCommandsAndServesNothing) {
  const mimic::test::Outcome r = mimic::test::run_mimic("");
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* k : {"usage: mimic <command>", "commands:", "run ", "view ", "subscribe ", "Start here"})
    EXPECT_NE(r.output.find(k), std::string::npos) << k << " in\n" << r.output;
  EXPECT_EQ(r.output.find("serving on"), std::string::npos) << r.output;
  const mimic::test::Outcome unknown = mimic::test::run_mimic("frobnicate");
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.output.find("unknown command 'frobnicate'"), std::string::npos) << unknown.output;
}

// Options are checked before the port is taken: with the port held by another program, a bad
// source is still named (exit 2), not "address already in use".
TEST(Overview, BadOptionsAreNamedEvenWhenThePortIsTaken) {
  const int holder = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(holder, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(holder, 1), 0);
  socklen_t n = sizeof a;
  ::getsockname(holder, reinterpret_cast<sockaddr*>(&a), &n);
  const std::string listen = "--listen 127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  mimic::test::Outcome r = mimic::test::run_mimic("run " + listen + " --source bogus:thing --duration 1");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("bogus"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("in use"), std::string::npos) << r.output;
  r = mimic::test::run_mimic("run " + listen + " --source actor:dance --duration 1");
  EXPECT_EQ(r.status, 2) << r.output;
  // A known source with a value out of its range is as much a usage error as an unknown one.
  r = mimic::test::run_mimic("run " + listen + " --source 'sim:walk?sensors=7' --duration 1");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("sensors=7"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("in use"), std::string::npos) << r.output;
  // Good options on the held port: the port is the problem, and it says so.
  r = mimic::test::run_mimic("run " + listen + " --duration 1");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("in use"), std::string::npos) << r.output;
  ::close(holder);
}

}  // namespace

}  // namespace overview_test
