// Bare `mimic`, typed to see what the tool is: an overview and the commands, at once, with no
// server started (the server is `mimic run`).
#include <gtest/gtest.h>

#include "run_mimic.h"

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

}  // namespace
