// End-to-end: the built `mimic retarget` on a shared CMU clip, and back on its own output.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include "mimic/core/file.h"
#include "run_mimic.h"
#include "test_data.h"

namespace retarget_cli_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

std::string temp_path(const std::string& name) {
  std::string path = ::testing::TempDir();
  path += "/retarget_cli_";
  path += std::to_string(::getpid());
  path += "_";
  path += name;
  return path;
}

TEST(RetargetCli, RetargetsACmuClipAndReadsItsOwnOutputBack) {
  const std::string out = temp_path("09_11.bvh"), again = temp_path("again.bvh");
  Outcome r = run_mimic("retarget --bvh '" + mimic::test::clip_path("09_11") + "' --out '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("31 joints, 96 channels, 166 frames at 120.00 fps"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("joint centres vs the clip"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("segments aligned on the clip's frame-0 T-pose"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wrote"), std::string::npos) << r.output;
  auto text = mimic::read_file(out);
  ASSERT_TRUE(text) << text.error().what();
  EXPECT_EQ(text->rfind("HIERARCHY\nROOT pelvis\n", 0), 0u);
  EXPECT_NE(text->find("JOINT l_elbow"), std::string::npos);
  EXPECT_NE(text->find("Frames: 166\n"), std::string::npos);

  r = run_mimic("retarget --bvh '" + out + "' --out '" + again + "' --default-body --out-scale 0.01");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("transferred onto the default body"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("23 joints, 58 channels, 166 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0.010000 m per unit"), std::string::npos) << r.output;
  // The centimetre file reads back at the right size when told its unit.
  const std::string third = temp_path("third.bvh");
  r = run_mimic("retarget --bvh '" + again + "' --scale 0.01 --out '" + third + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("max 0.0"), std::string::npos) << r.output;
  std::remove(third.c_str());
  std::remove(out.c_str());
  std::remove(again.c_str());
}

TEST(RetargetCli, BadUsageAndBadInputAreReported) {
  Outcome r = run_mimic("retarget --out x.bvh");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--bvh"), std::string::npos) << r.output;
  r = run_mimic("retarget --bvh a.bvh --out b.bvh --scale zero");
  EXPECT_EQ(r.status, 2);
  r = run_mimic("retarget --bvh a.bvh --out b.bvh --scale -2");
  EXPECT_EQ(r.status, 2);
  r = run_mimic("retarget --bvh /nonexistent/a.bvh --out b.bvh");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("/nonexistent/a.bvh"), std::string::npos) << r.output;
  r = run_mimic("retarget --help");
  EXPECT_EQ(r.status, 0);
  for (const char* opt : {"--bvh", "--out", "--scale", "--out-scale", "--default-body"})
    EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
}

}  // namespace

}  // namespace retarget_cli_test
