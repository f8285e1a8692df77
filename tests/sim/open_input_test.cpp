#include "mimic/sim/open_input.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace open_input_test {

namespace {

mimic::Result<std::unique_ptr<mimic::devices::InputSource>> open(const char* text) {
  auto spec = mimic::devices::parse_source_spec(text);
  if (!spec) return tl::unexpected(spec.error());
  return mimic::sim::open_input_source(*spec);
}

}  // namespace

TEST(OpenInput, SimulatedSpaceMouseModelFromIds) {
  auto src = open("spacemouse:sim?vid=256f&pid=c62e&seed=3");
  ASSERT_TRUE(src) << src.error().what();
  ASSERT_TRUE((*src)->start());
  mimic::devices::InputFrame f;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  bool got = false;
  while (!got && std::chrono::steady_clock::now() < end) {
    got = (*src)->poll(f);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_TRUE(got);
  EXPECT_NE((*src)->status().description.find("SpaceMouse Wireless"), std::string::npos);
  (*src)->stop();
}

TEST(OpenInput, SerialSourcesComeBackUnstarted) {
  auto sb = open("spaceball:/dev/does-not-exist?probe=0.5&tscale=4000");
  ASSERT_TRUE(sb) << sb.error().what();
  EXPECT_EQ((*sb)->status().state, mimic::devices::DeviceState::disconnected);
  auto mg = open("magellan:/dev/does-not-exist?settle=0.1");
  ASSERT_TRUE(mg) << mg.error().what();
}

TEST(OpenInput, ClearErrors) {
  auto wrong = open("sim:walk");
  ASSERT_FALSE(wrong);
  EXPECT_NE(wrong.error().message.find("not a 6-DOF input device"), std::string::npos);
  auto bad_id = open("spacemouse:sim?pid=xyz");
  ASSERT_FALSE(bad_id);
  EXPECT_NE(bad_id.error().message.find("16-bit hex id"), std::string::npos);
  auto unknown_model = open("spacemouse:sim?vid=1234&pid=1");
  ASSERT_FALSE(unknown_model);
  auto bad_param = open("spaceball:/dev/ttyS0?probe=-1");
  ASSERT_FALSE(bad_param);
  auto seed_on_real = open("spacemouse?seed=1");
  ASSERT_FALSE(seed_on_real);
}

}  // namespace open_input_test
