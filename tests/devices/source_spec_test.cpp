// Source specs: "<scheme>:<target>?key=value&...", with errors that say what is wrong.
#include <gtest/gtest.h>

#include "mimic/devices/source.h"

namespace mimic::devices::source_spec_test {
namespace {

TEST(SourceSpec, FlockWithParameters) {
  auto s = parse_source_spec("flock:/dev/ttyUSB0?birds=4&baud=115200&format=pos_quat&erc=1");
  ASSERT_TRUE(s) << s.error().what();
  EXPECT_EQ(s->scheme, "flock");
  EXPECT_EQ(s->target, "/dev/ttyUSB0");
  EXPECT_EQ(s->params.at("birds"), "4");
  EXPECT_EQ(s->params.at("baud"), "115200");
  EXPECT_EQ(s->params.at("format"), "pos_quat");
  EXPECT_EQ(s->params.size(), 4u);
  EXPECT_EQ(s->text, "flock:/dev/ttyUSB0?birds=4&baud=115200&format=pos_quat&erc=1");
}

TEST(SourceSpec, TargetsOptionalWhereTheSchemeAllows) {
  auto a = parse_source_spec("spacemouse");
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_EQ(a->scheme, "spacemouse");
  EXPECT_TRUE(a->target.empty());
  auto b = parse_source_spec("sim:walk");
  ASSERT_TRUE(b);
  EXPECT_EQ(b->target, "walk");
  auto c = parse_source_spec("sim?seed=3");
  ASSERT_TRUE(c) << c.error().what();
  EXPECT_TRUE(c->target.empty());
  EXPECT_EQ(c->params.at("seed"), "3");
  auto d = parse_source_spec("replay:session.mlog");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->target, "session.mlog");
  // A target may itself contain ':' (only the first one splits).
  auto e = parse_source_spec("bvh:data/a:b.bvh");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->target, "data/a:b.bvh");
}

void expect_error(const char* text, const char* fragment) {
  auto s = parse_source_spec(text);
  ASSERT_FALSE(s) << text;
  EXPECT_NE(s.error().message.find(fragment), std::string::npos) << text << " -> " << s.error().message;
}

TEST(SourceSpec, ClearErrors) {
  expect_error("", "empty source spec");
  expect_error("flok:/dev/ttyS0", "unknown scheme 'flok'");
  expect_error("flok:/dev/ttyS0", "known: flock, spaceball");
  expect_error("flock", "needs a serial device path");
  expect_error("flock:?birds=2", "needs a serial device path");
  expect_error("replay:", "needs a log file path");
  expect_error("flock:/dev/ttyS0?", "nothing after '?'");
  expect_error("flock:/dev/ttyS0?birds", "'birds' is not key=value");
  expect_error("flock:/dev/ttyS0?=4", "is not key=value");
  expect_error("flock:/dev/ttyS0?birds=", "'birds' has no value");
  expect_error("flock:/dev/ttyS0?birds=2&&baud=9600", "stray '&'");
  expect_error("flock:/dev/ttyS0?brids=4", "unknown parameter 'brids' for flock");
  expect_error("flock:/dev/ttyS0?brids=4", "birds, baud");
  expect_error("flock:/dev/ttyS0?birds=4&birds=5", "given twice");
  expect_error("flock:/dev/ttyS0?birds=15", "birds=15: must be in 1..14");
  expect_error("flock:/dev/ttyS0?birds=four", "expects an integer");
  expect_error("flock:/dev/ttyS0?baud=12345", "expects one of 2400");
  expect_error("flock:/dev/ttyS0?mode=burst", "expects one of stream,point");
  expect_error("flock:/dev/ttyS0?erc=maybe", "expects a boolean");
  expect_error("flock:/dev/ttyS0?rate=500", "must be in 14..144");
  expect_error("spaceball:/dev/ttyS0?birds=2", "unknown parameter 'birds' for spaceball");
}

TEST(SourceSpec, ErrorCodes) {
  EXPECT_EQ(parse_source_spec("nope:x").error().code, Errc::invalid_argument);
  EXPECT_EQ(parse_source_spec("flock:/x?birds=99").error().code, Errc::out_of_range);
}

}  // namespace
}  // namespace mimic::devices::source_spec_test
