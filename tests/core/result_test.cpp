#include <gtest/gtest.h>

#include <filesystem>

#include "mimic/core/file.h"
#include "mimic/core/result.h"

namespace mimic::result_test {

TEST(Result, CarriesCodeAndMessage) {
  Result<int> r = fail(Errc::parse_error, "clip.bvh:3: expected '{'");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::parse_error);
  EXPECT_EQ(r.error().what(), "parse error: clip.bvh:3: expected '{'");
}

TEST(File, AtomicWriteThenReadRoundTrips) {
  const auto path = (std::filesystem::temp_directory_path() / "mimic_file_test.bin").string();
  const std::string bytes("a\0b\r\n\xff", 6);
  ASSERT_TRUE(write_file_atomic(path, bytes));
  auto back = read_file(path);
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, bytes);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  std::filesystem::remove(path);
}

TEST(File, AWriteIntoAMissingFolderNamesThePathGiven) {
  // The temporary file beside the target is an implementation detail: the error names the
  // path the caller asked for, and only that.
  const std::string path = "/nonexistent-mimic-dir/x.obj";
  const Status st = write_file_atomic(path, "bytes");
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().code, Errc::io_error);
  EXPECT_NE(st.error().message.find(path + ":"), std::string::npos) << st.error().message;
  EXPECT_EQ(st.error().message.find(".tmp"), std::string::npos) << st.error().message;
}

TEST(File, MissingFileIsAnIoError) {
  auto r = read_file("/nonexistent/dir/file");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::io_error);
  EXPECT_NE(r.error().message.find("/nonexistent/dir/file"), std::string::npos);
}

}  // namespace mimic::result_test
