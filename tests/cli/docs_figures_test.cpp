// Figures the documentation quotes, read from the documents and compared with what the
// program prints: a figure that drifts (the skin gains a ring, the body model a field) fails
// here instead of misleading a reader. Each check names the document and the command.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "run_mimic.h"

namespace docs_figures_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

std::string repo_file(const std::string& relative) {
  // MIMIC_TEST_DATA_DIR is <repo>/tests/data.
  const std::filesystem::path path = std::filesystem::path(MIMIC_TEST_DATA_DIR) / ".." / ".." / relative;
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// "9,588" -> 9588.
long number(std::string text) {
  std::erase(text, ',');
  return std::stol(text);
}

// The first match of `pattern` in `text`, its capture groups as numbers.
std::vector<long> figures(const std::string& text, const std::string& pattern, const std::string& where) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex(pattern))) {
    ADD_FAILURE() << where << ": no figure matching " << pattern;
    return {};
  }
  std::vector<long> out;
  for (size_t i = 1; i < m.size(); ++i) out.push_back(number(m[i].str()));
  return out;
}

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mimic_docs_" + std::to_string(::getpid()) + "_" + name)).string();
}

// Triangles of the default body at each LOD, as the realtime skin (the default of every
// command) builds it: `mimic mesh --pose zero --lod N`.
std::vector<long> lod_triangles() {
  std::vector<long> out;
  const std::string obj = temp("lod.obj");
  for (int lod = 0; lod < 4; ++lod) {
    const Outcome r = run_mimic("mesh --pose zero --lod " + std::to_string(lod) + " --out '" + obj + "'");
    EXPECT_EQ(r.status, 0) << r.output;
    const auto f = figures(r.output, R"(mesh +\d+ vertices, (\d+) triangles)", "mimic mesh");
    out.push_back(f.empty() ? -1 : f[0]);
  }
  std::filesystem::remove(obj);
  return out;
}

TEST(DocsFigures, LodTriangleCountsAreTheProducts) {
  const std::vector<long> product = lod_triangles();
  ASSERT_EQ(product.size(), 4u);
  // README.md's LOD pictures.
  EXPECT_EQ(
      figures(repo_file("README.md"),
              R"(LOD 0: ([\d,]+) triangles \| LOD 1: ([\d,]+) \| LOD 2: ([\d,]+) \| LOD 3: ([\d,]+))", "README.md"),
      product);
  // docs/viewer.md's table of LODs.
  const std::string viewer = repo_file("docs/viewer.md");
  std::vector<long> table;
  for (int lod = 0; lod < 4; ++lod) {
    const auto f = figures(viewer, "\\| " + std::to_string(lod) + R"( \| ([\d,]+) \|)", "docs/viewer.md");
    table.push_back(f.empty() ? -1 : f[0]);
  }
  EXPECT_EQ(table, product) << "docs/viewer.md, the LOD table";
  // mimic mesh --help: the coarsest LOD.
  const Outcome help = run_mimic("mesh --help");
  EXPECT_EQ(figures(help.output, R"(to 3 \(([\d,]+) triangles\))", "mimic mesh --help"), std::vector<long>{product[3]});
}

TEST(DocsFigures, TheBodyModelSizeIsTheServers) {
  // What `mimic run` sends every subscriber on joining: it prints the size at start.
  const Outcome r = run_mimic("run --listen 127.0.0.1:0 --duration 0.3 --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto served = figures(r.output, R"(model (\d+) bytes)", "mimic run");
  const auto documented =
      figures(repo_file("docs/protocol.md"),
              R"(body model sent on join \(default body, compact JSON\) \| ([\d,]+) bytes)", "docs/protocol.md");
  EXPECT_EQ(documented, served);
}

TEST(DocsFigures, TheExportedWalkIsWhatGltfExportSays) {
  const std::string glb = temp("walk.glb");
  const Outcome r = run_mimic("export --motion walk --out '" + glb + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  std::filesystem::remove(glb);
  const auto product =
      figures(r.output, R"((\d+) vertices, (\d+) triangles, (\d+) joints, .*; (\d+) keyframes)", "mimic export");
  const auto documented = figures(
      repo_file("docs/gltf-export.md"),
      R"(--motion walk` \(([\d,]+) vertices, ([\d,]+) triangles, (\d+) joints, (\d+) keys\))", "docs/gltf-export.md");
  EXPECT_EQ(documented, product);
}

// docs/troubleshooting.md quotes error messages for readers to search for: each one quoted
// there is what the command prints (and exits with), word for word.
TEST(DocsFigures, TroubleshootingQuotesWhatTheProductPrints) {
  // The guide wraps its lines: compare with every run of white space as one space.
  std::string doc = std::regex_replace(repo_file("docs/troubleshooting.md"), std::regex(R"(\s+)"), " ");
  const std::string out = temp("missing-folder") + "/x.obj";
  struct Case {
    std::string command, quote;
    int status;
  };
  const Case cases[] = {
      {"run --listen 127.0.0.1:0 --duration 1 --source bogus",
       "source 'bogus': unknown scheme 'bogus' (sources: sim, bvh, replay, flock, vmc, vrpn, osc-trackers, actor)", 2},
      {"mesh --time 1e9 --out x.obj", "--time: expects a finite number [0 - 3600], got '1e9'", 2},
      {"export --motion walk --lod 7 --out x.glb", "--lod: Value 7 not in range 0 to 3", 2},
      {"export --motion walk --fps 0 --out x.glb", "--fps: expects a finite number (0 - 240], got '0'", 2},
      {"mesh --bogus", "unknown option --bogus", 2},
      {"mesh --out '" + out + "'", ": cannot create: No such file or directory", 1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE("mimic " + c.command);
    EXPECT_NE(doc.find(c.quote), std::string::npos) << "docs/troubleshooting.md does not quote: " << c.quote;
    const Outcome r = run_mimic(c.command);
    EXPECT_EQ(r.status, c.status) << r.output;
    EXPECT_NE(r.output.find(c.quote), std::string::npos) << r.output;
  }
}

}  // namespace

}  // namespace docs_figures_test
