// End to end: text that comes from files and peers (a log header's source, a scene name) reaches
// the terminal escaped, and a log with bytes after its end record is reported, not replayed in
// silence.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "mimic_proc.h"
#include "replay_csv.h"

namespace untrusted_text_test {

namespace {

namespace fs = std::filesystem;
using mimic::test::Proc;

std::string work_dir() {
  const fs::path d = fs::temp_directory_path() / ("mimic_cli_untrusted_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d.string();
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void spit(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// CRC-32 (IEEE, as docs/log-format.md says) of a record's length, type and payload.
uint32_t crc32(const std::string& bytes) {
  uint32_t crc = ~0u;
  for (const char ch : bytes) {
    crc ^= static_cast<uint8_t>(ch);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void put_u32(std::string& s, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) s[at + size_t(k)] = static_cast<char>((v >> (8 * k)) & 0xFF);
}

// A real recording whose header's source is replaced by `json_value` (JSON-escaped text), with
// the header record's length and CRC made good again: a well-formed log that says what an
// attacker wants.
std::string log_with_source(const std::string& dir, const std::string& json_value) {
  const std::string path = dir + "/recorded.mlog";
  Proc rec({"record", "--source", "sim:idle?sensors=3", "--duration", "0.3", "--out", path, "--quiet"});
  EXPECT_EQ(rec.wait(30.0), 0) << rec.err();
  std::string bytes = slurp(path);
  const size_t header = 12;  // after the magic number and the version
  uint32_t len = 0;
  for (int k = 0; k < 4; ++k) len |= uint32_t(uint8_t(bytes[header + size_t(k)])) << (8 * k);
  std::string json = bytes.substr(header + 5, len);
  const std::string old_value = "\"sim:idle?sensors=3\"";
  const size_t at = json.find(old_value);
  EXPECT_NE(at, std::string::npos) << json;
  if (at == std::string::npos) return path;
  json.replace(at, old_value.size(), "\"" + json_value + "\"");
  std::string record(5, '\0');
  put_u32(record, 0, static_cast<uint32_t>(json.size()));
  record[4] = bytes[header + 4];
  record += json;
  std::string crc(4, '\0');
  put_u32(crc, 0, crc32(record));
  const std::string out = dir + "/hostile.mlog";
  spit(out, bytes.substr(0, header) + record + crc + bytes.substr(header + 9 + len));
  return out;
}

// No byte of `text` can start a terminal control or reorder or hide what is shown.
void expect_inert(const std::string& text) {
  EXPECT_EQ(text.find('\x1b'), std::string::npos) << text;
  EXPECT_EQ(text.find('\x07'), std::string::npos) << text;
  EXPECT_EQ(text.find("\xc2\x9b"), std::string::npos) << text;      // C1 CSI
  EXPECT_EQ(text.find("\xe2\x80\xae"), std::string::npos) << text;  // U+202E
  EXPECT_EQ(text.find("\xe2\x80\x8b"), std::string::npos) << text;  // U+200B
}

constexpr const char* kHostile = "evil\\u001b]0;owned\\u0007\\u009b31m\\u202etxt.exe avat\\u200bar1";

TEST(UntrustedText, ReplayShowsAHostileLogSourceEscaped) {
  const std::string log = log_with_source(work_dir(), kHostile);
  Proc rep({"replay", log, "--speed", "0"});
  ASSERT_EQ(rep.wait(30.0), 0) << rep.err();
  expect_inert(rep.err());
  // Shown, visibly: the reader sees that the name holds an escape and an invisible character.
  EXPECT_NE(rep.err().find("evil\\u001b]0;owned\\u0007\\u009b31m\\u202etxt.exe avat\\u200bar1"), std::string::npos)
      << rep.err();
}

TEST(UntrustedText, RunWithAReplaySourceShowsItEscaped) {
  const std::string log = log_with_source(work_dir(), kHostile);
  Proc run({"run", "--listen", "127.0.0.1:0", "--source", "replay:" + log, "--duration", "1", "--json"});
  EXPECT_EQ(run.wait(60.0), 0) << run.err();
  expect_inert(run.out());
  expect_inert(run.err());
  EXPECT_NE((run.out() + run.err()).find("\\u202etxt.exe"), std::string::npos) << run.out() << run.err();
}

#if MIMIC_HAVE_NATS  // a scene name comes from a nats:// address
TEST(UntrustedText, SceneNameInAnErrorIsEscaped) {
  Proc sub({"subscribe", "--connect", "nats://127.0.0.1:1/sc\x1b]0;owned\x07\xe2\x80\xae", "--duration", "1"});
  EXPECT_NE(sub.wait(30.0), 0);
  expect_inert(sub.err());
  EXPECT_NE(sub.err().find("\\u001b]0;owned\\u0007\\u202e"), std::string::npos) << sub.err();
  Proc run({"run", "--listen", "127.0.0.1:0", "--nats", "nats://127.0.0.1:1", "--scene",
            "a\xc2\x9b"
            "2J",
            "--duration", "1"});
  EXPECT_NE(run.wait(30.0), 0);
  expect_inert(run.err());
  EXPECT_NE(run.err().find("a\\u009b2J"), std::string::npos) << run.err();
}
#endif

// Bytes after the end record: every sample is still replayed, the offset is named, exit 1
// (docs/log-format.md).
TEST(UntrustedText, BytesAfterTheEndRecordAreReported) {
  const std::string dir = work_dir();
  const std::string log = dir + "/clean.mlog", dirty = dir + "/dirty.mlog";
  Proc rec({"record", "--source", "sim:idle?sensors=3", "--duration", "0.3", "--out", log, "--quiet"});
  ASSERT_EQ(rec.wait(30.0), 0) << rec.err();
  const std::string bytes = slurp(log);
  spit(dirty, bytes + "\x1b[2Jappended");
  Proc clean({"replay", log, "--csv", "--speed", "0"});
  ASSERT_EQ(clean.wait(30.0), 0) << clean.err();
  Proc rep({"replay", dirty, "--csv", "--speed", "0"});
  EXPECT_EQ(rep.wait(30.0), 1) << rep.err();
  EXPECT_EQ(mimic::test::parse_csv(rep.out()).size(), mimic::test::parse_csv(clean.out()).size());
  EXPECT_NE(rep.err().find("damage at byte " + std::to_string(bytes.size())), std::string::npos) << rep.err();
  EXPECT_NE(rep.err().find("after the end record"), std::string::npos) << rep.err();
}

}  // namespace

}  // namespace untrusted_text_test
