// End-to-end: the interactive `mimic view` in a real GLFW window on a virtual X display (Xvfb,
// started here on a free display number), from the local pipeline and connected to a running
// `mimic run`; the window's last frame is captured and checked.
#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "mimic/render/image.h"
#include "nats_broker.h"
#include "run_mimic.h"
#include "test_data.h"

namespace view_window_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

// An Xvfb server on a display number it picks itself (-displayfd: no race between tests run in
// parallel); stopped at the end of the test. Another suite's Xvfb on the same number that was
// still shutting down can leave the new server without a reachable socket (seen once with two
// suites side by side): a server no client can reach is replaced by a fresh one.
class VirtualDisplay {
 public:
  VirtualDisplay() {
    for (int attempt = 0; attempt < 5; ++attempt) {
      start();
      if (!display_.empty() && reachable()) return;
      stop();
      display_.clear();
      ::usleep(300 * 1000);
    }
  }
  ~VirtualDisplay() { stop(); }
  const std::string& display() const { return display_; }

 private:
  void start() {
    int fds[2];
    if (::pipe(fds) != 0) return;
    const std::string fd = std::to_string(fds[1]);
    std::vector<std::string> args = {"Xvfb", "-displayfd", fd, "-screen", "0", "1024x768x24", "-nolisten", "tcp"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    const bool spawned = posix_spawnp(&pid_, "Xvfb", &fa, nullptr, argv.data(), environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    if (!spawned) {
      pid_ = -1;
      ::close(fds[0]);
      return;
    }
    // Xvfb writes the display number once it accepts connections (EOF if it dies first).
    std::string number;
    char c = 0;
    while (::read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    ::close(fds[0]);
    if (!number.empty()) display_ = ":" + number;
  }
  // A client can connect: through the socket file or the abstract socket of the same name, as
  // Xlib and xcb try them.
  bool reachable() const {
    const std::string path = "/tmp/.X11-unix/X" + display_.substr(1);
    for (const bool abstract : {false, true}) {
      sockaddr_un addr{};
      addr.sun_family = AF_UNIX;
      std::memcpy(addr.sun_path + (abstract ? 1 : 0), path.data(), path.size());
      const socklen_t size = socklen_t(offsetof(sockaddr_un, sun_path) + path.size() + (abstract ? 1 : 0));
      const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (fd < 0) return false;
      const bool connected = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), size) == 0;
      ::close(fd);
      if (connected) return true;
    }
    return false;
  }
  void stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
      pid_ = -1;
    }
  }
  pid_t pid_ = -1;
  std::string display_;
};

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mimic_view_window_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

// Pixels of the avatar's shirt (blue) and of the ImGui panel (dark, top-left corner).
int shirt_pixels(const mimic::render::Image& image) {
  int n = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      n += p[2] > p[0] + 40 && p[2] > 90;
    }
  return n;
}
int dark_pixels_top_left(const mimic::render::Image& image) {
  int n = 0;
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 120; ++x) {
      const uint8_t* p = image.pixel(x, y);
      n += p[0] < 110 && p[1] < 110 && p[2] < 120;  // the panel: dark grey, 75% opaque
    }
  return n;
}

TEST(ViewWindow, DrawsTheLocalPipelineWithItsPanel) {
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);  // for the program run below
  const std::string out = temp("local.png");
  const Outcome r = run_mimic("view --source 'sim:walk?sensors=11' --frames 15 --no-vsync --size 400x300 --capture '" +
                              out + "' --overlay skeleton");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("15 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("avatar1: sim:walk?sensors=11"), std::string::npos) << r.output;
  auto image = mimic::render::read_png(out);
  ASSERT_TRUE(image) << r.output;
  EXPECT_EQ(image->width, 400);
  EXPECT_EQ(image->height, 300);
  EXPECT_GT(shirt_pixels(*image), 800);
  EXPECT_GT(dark_pixels_top_left(*image), 2000);  // the ImGui status panel
  std::filesystem::remove(out);
}

// Column of the shirt's pixels' centre, −1 when there are none.
double shirt_centre_x(const mimic::render::Image& image) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      if (p[2] > p[0] + 40 && p[2] > 90) sum += x, ++n;
    }
  return n > 0 ? sum / n : -1.0;
}

TEST(ViewWindow, TheOrbitCameraKeepsAWalkerInTheMiddle) {
  // The built-in walk leaves the first framing within about three seconds; 500 frames take
  // longer than that on any machine, so without following the capture shows an empty floor.
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);
  const std::string out = temp("follow.png");
  const Outcome r = run_mimic(
      "view --source 'sim:walk?sensors=11' --frames 500 --lod 3 --size 400x300 --no-panel --capture '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  auto image = mimic::render::read_png(out);
  ASSERT_TRUE(image) << r.output;
  EXPECT_GT(shirt_pixels(*image), 800);
  const double cx = shirt_centre_x(*image);
  EXPECT_GT(cx, 0.3 * image->width);
  EXPECT_LT(cx, 0.7 * image->width);
  std::filesystem::remove(out);
}

// The camera's angle from the first avatar's face, as the viewer reports it on exit; −1 if absent.
double degrees_from_face(const std::string& output) {
  const size_t at = output.find("camera    ");
  return at == std::string::npos ? -1.0 : std::atof(output.c_str() + at + 10);
}

TEST(ViewWindow, OpensFacingTheAvatarAndKeepsItsPresetAsItTurns) {
  // The built-in walk turns a full circle in 6.6 s. The window opens on the walker's face and
  // stays on it as it goes round (the camera turns with it); --camera back stays behind it.
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);
  const std::string common = "view --source sim:walk --frames 300 --lod 3 --size 320x240 --no-panel";
  const Outcome front = run_mimic(common);
  ASSERT_EQ(front.status, 0) << front.output;
  const double front_deg = degrees_from_face(front.output);
  ASSERT_GE(front_deg, 0.0) << front.output;
  EXPECT_LT(front_deg, 40.0) << front.output;
  const Outcome back = run_mimic(common + " --camera back");
  ASSERT_EQ(back.status, 0) << back.output;
  EXPECT_GT(degrees_from_face(back.output), 140.0) << back.output;
  const Outcome left = run_mimic(common + " --camera left");
  ASSERT_EQ(left.status, 0) << left.output;
  EXPECT_NEAR(degrees_from_face(left.output), 90.0, 40.0) << left.output;
}

// What of the avatars a capture shows where it should not: pixels under or below the status
// panel, or on the window's right or bottom edge (cut by it).
struct Framing {
  int body = 0, left_of_panel = 0, on_edge = 0, panel_right = 0;
};

Framing framing_of(const mimic::render::Image& image) {
  Framing f;
  // The panel: the dark box from the top-left corner (its title bar is blue); its right edge
  // along row 45.
  for (int x = 0; x < image.width; ++x) {
    const uint8_t* p = image.pixel(x, 45);
    if (p[0] < 110 && p[1] < 110 && p[2] < 120) f.panel_right = x;
  }
  int panel_bottom = 0;
  for (int y = 0; y < image.height; ++y) {
    const uint8_t* p = image.pixel(f.panel_right / 2, y);
    if (p[0] < 110 && p[1] < 110 && p[2] < 120) panel_bottom = y;
  }
  constexpr uint8_t kBackground[3] = {237, 240, 245};
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      if (x <= f.panel_right + 2 && y <= panel_bottom + 2) continue;  // the panel itself
      const uint8_t* p = image.pixel(x, y);
      if (std::abs(p[0] - kBackground[0]) + std::abs(p[1] - kBackground[1]) + std::abs(p[2] - kBackground[2]) <= 24)
        continue;
      ++f.body;
      f.left_of_panel += x <= f.panel_right;
      f.on_edge += x >= image.width - 2 || y >= image.height - 2;
    }
  return f;
}

TEST(ViewWindow, TwoAvatarsAreFramedWholeBesideThePanel) {
  // The README's two avatars side by side: both whole in the window (nothing of them on its
  // right or bottom edge) and none of them left of the status panel's right edge, when the
  // window opens and after the walker has walked for seconds (it circles away from the one
  // standing: 700 frames take longer than its first quarter circle on any machine).
  VirtualDisplay display;
  ASSERT_FALSE(display.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", display.display().c_str(), 1);
  for (int frames : {12, 700}) {
    SCOPED_TRACE("after " + std::to_string(frames) + " frames");
    const std::string out = temp("two.png");
    const Outcome r =
        run_mimic("view --source 'sim:walk?sensors=11;sim:idle?sensors=6' --frames " + std::to_string(frames) +
                  " --no-vsync --no-grid --lod 3 --size 640x480 --capture '" + out + "'");
    ASSERT_EQ(r.status, 0) << r.output;
    auto image = mimic::render::read_png(out);
    ASSERT_TRUE(image) << r.output;
    std::filesystem::remove(out);
    const Framing f = framing_of(*image);
    ASSERT_GT(f.panel_right, 60) << "the panel is drawn";
    EXPECT_GT(f.body, 3000) << "both avatars drawn";
    EXPECT_EQ(f.left_of_panel, 0) << "avatar pixels under or below the panel (right edge " << f.panel_right << " px)";
    EXPECT_EQ(f.on_edge, 0) << "an avatar cut by the window's edge";
    EXPECT_NE(r.output.find("avatar2: sim:idle?sensors=6"), std::string::npos) << r.output;
  }
}

TEST(ViewWindow, ConnectsToMimicRunAndDrawsEveryAvatarItServes) {
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);
  mimic::test::Child host({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--source", "sim:walk",
                           "--source", "sim:idle?seed=2", "--duration", "20", "--quiet"});
  const std::string line = host.line();
  ASSERT_EQ(line.rfind("serving on ", 0), 0u) << line;
  const std::string endpoint = line.substr(std::string("serving on ").size());
  const std::string out = temp("connected.png");
  const Outcome r =
      run_mimic("view --connect " + endpoint + " --frames 40 --no-vsync --size 400x300 --capture '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  // Both avatars arrived as body models and are deformed here from pose frames.
  EXPECT_NE(r.output.find("avatar1#"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("avatar2#"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find(" 0 frames,"), std::string::npos) << r.output;
  auto image = mimic::render::read_png(out);
  ASSERT_TRUE(image) << r.output;
  EXPECT_GT(shirt_pixels(*image), 800);
  std::filesystem::remove(out);
  // A server that is not there: a clear error, exit 1.
  const Outcome none = run_mimic("view --connect 127.0.0.1:1 --frames 1");
  EXPECT_EQ(none.status, 1);
  EXPECT_NE(none.output.find("cannot connect"), std::string::npos) << none.output;
}

TEST(ViewWindow, FirstPersonSeesTheAvatarOppositeAndNotItself) {
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);
  // Two avatars 3 m apart facing each other, and a third one behind the first.
  mimic::test::Child host({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--source", "sim:idle",
                           "--place", "0,0", "--source", "sim:idle?seed=2", "--place", "0,3,180", "--source",
                           "sim:idle?seed=3", "--place", "0,-2", "--duration", "300", "--quiet"});
  const std::string line = host.line();
  ASSERT_EQ(line.rfind("serving on ", 0), 0u) << line;
  const std::string endpoint = line.substr(std::string("serving on ").size());
  auto look = [&](int avatar) {
    const std::string out = temp("eyes.png");
    const Outcome r = run_mimic("view --connect " + endpoint + " --eyes " + std::to_string(avatar) +
                                " --frames 20 --no-vsync --no-panel --size 480x360 --capture '" + out + "'");
    EXPECT_EQ(r.status, 0) << r.output;
    auto image = mimic::render::read_png(out);
    std::filesystem::remove(out);
    return image ? *image : mimic::render::Image{};
  };
  // From the first avatar's eyes: the second one, 3 m ahead and facing us, is in view.
  const mimic::render::Image first = look(1);
  ASSERT_GT(first.width, 0);
  EXPECT_GT(shirt_pixels(first), 300);
  // From the third avatar's eyes (2 m behind the first, facing the same way): the first one's
  // back blocks the middle of the view.
  const mimic::render::Image third = look(3);
  EXPECT_GT(shirt_pixels(third), shirt_pixels(first));
  // From the second avatar's eyes, looking back along −Z: both others are in front.
  const mimic::render::Image second = look(2);
  EXPECT_GT(shirt_pixels(second), 300);
  // An orbit view of the same scene is not what any of them sees.
  EXPECT_NE(first.rgba, second.rgba);
}

// Pixels that differ from the background (with --no-grid: avatars), and their mean column.
struct Figure {
  int pixels = 0;
  double centre_x = -1;
  int top = -1, bottom = -1;  // rows
};
Figure figure_of(const mimic::render::Image& image) {
  constexpr uint8_t kBackground[3] = {237, 240, 245};
  Figure f;
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      if (std::abs(p[0] - kBackground[0]) + std::abs(p[1] - kBackground[1]) + std::abs(p[2] - kBackground[2]) <= 24)
        continue;
      ++f.pixels;
      sum += x;
      if (f.top < 0) f.top = y;
      f.bottom = y;
    }
  if (f.pixels > 0) f.centre_x = sum / f.pixels;
  return f;
}

// First person in the side-by-side row, as a headset wearer standing in it sees: straight
// ahead (--look 0), nobody (the neighbour stands beside it, and its own head is not drawn around
// the eye); entering the eyes without --look, the look turned to the neighbour as nobody is
// ahead; and so with the look turned by hand (a drag, or --look). The neighbour whole in
// profile, 1.5 m away, in the middle of the view and a sane part of it; from either side.
TEST(ViewWindow, FirstPersonInTheRowSeesTheNeighbourWhenLookingAtIt) {
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);
  auto look = [&](const std::string& options) {
    const std::string out = temp("row_eyes.png");
    const Outcome r =
        run_mimic("view --source 'sim:idle?sensors=6;sim:idle?sensors=6&seed=2' " + options +
                  " --frames 12 --no-vsync --no-panel --no-grid --lod 2 --size 480x360 --capture '" + out + "'");
    EXPECT_EQ(r.status, 0) << r.output;
    auto image = mimic::render::read_png(out);
    std::filesystem::remove(out);
    EXPECT_TRUE(image) << r.output;
    return image ? figure_of(*image) : Figure{};
  };
  const int all = 480 * 360;
  const Figure ahead = look("--eyes 1 --look 0");
  EXPECT_LT(ahead.pixels, all / 100) << "avatar 1 sees itself or someone ahead";
  // The second avatar stands 1.5 m to the first one's left (+X): 90° to the left.
  for (const char* options : {"--eyes 1", "--eyes 2", "--eyes 1 --look 90", "--eyes 2 --look=-90"}) {
    SCOPED_TRACE(options);
    const Figure f = look(options);
    EXPECT_GT(f.pixels, all * 15 / 1000);
    EXPECT_LT(f.pixels, all * 40 / 100);
    EXPECT_NEAR(f.centre_x, 240.0, 80.0);
    // Seen from eye height: the head above the middle of the view, the feet near its bottom.
    EXPECT_GT(f.top, 360 / 4);
    EXPECT_LT(f.top, 360 / 2);
    EXPECT_GT(f.bottom, 360 * 8 / 10);
  }
}

// A scene published through a NATS broker: `mimic view --connect nats://HOST:PORT/SCENE` takes
// it from the broker (a relay inside the viewer) and draws every avatar of it.
TEST(ViewWindow, ConnectsToASceneOnANatsBroker) {
  const Outcome probe = run_mimic("run --listen 127.0.0.1:0 --nats nats://127.0.0.1:1 --duration 0.1 --quiet");
  if (probe.output.find("no NATS support") != std::string::npos) GTEST_SKIP() << "built without NATS";
  ASSERT_FALSE(mimic::test::nats_server_binary().empty()) << "nats-server missing: run scripts/setup.sh";
  mimic::test::NatsBroker broker;
  broker.configure("view");
  ASSERT_TRUE(broker.start());
  VirtualDisplay x;
  ASSERT_FALSE(x.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", x.display().c_str(), 1);
  mimic::test::Child host({mimic::test::mimic_binary(), "run", "--listen", "127.0.0.1:0", "--nats",
                           broker.url_as("hostV"), "--scene", "stage", "--nats-name", "hostV", "--source", "sim:walk",
                           "--source", "sim:idle?seed=2", "--duration", "30", "--quiet"});
  const std::string line = host.line();
  ASSERT_NE(line.find("publishing scene 'stage'"), std::string::npos) << line;
  const std::string out = temp("nats.png");
  const std::string target = broker.url_as("relay") + "/stage";  // a viewer reads as a relay does
  const Outcome r =
      run_mimic("view --connect " + target + " --frames 120 --no-vsync --size 400x300 --capture '" + out + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  // Both avatars came through the broker, under their publisher's names, deformed here from
  // pose frames of the lean stream.
  EXPECT_NE(r.output.find("hostV/avatar1#"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("hostV/avatar2#"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("scene     " + target + ": "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("pose frames (lean)"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find(" 0 frames,"), std::string::npos) << r.output;
  auto image = mimic::render::read_png(out);
  ASSERT_TRUE(image) << r.output;
  EXPECT_GT(shirt_pixels(*image), 800);
  std::filesystem::remove(out);
  // A scene name that cannot be a subject: a clear error, exit 1.
  const Outcome bad = run_mimic("view --connect " + broker.url() + "/a.b --frames 1");
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.output.find("may only hold A-Z a-z 0-9 _ -"), std::string::npos) << bad.output;
}

// Avatars a command reports: "avatar N:" lines of `mimic run`, "avatar    avatarN:" of `mimic view`.
size_t count_of(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// `mimic view --source` takes every source form `mimic run --source` does (one scene builder
// for both): each form runs in both commands with the same avatars, and a form neither takes is
// a usage error in both.
TEST(ViewWindow, TakesEverySourceFormMimicRunTakes) {
  VirtualDisplay display;
  ASSERT_FALSE(display.display().empty()) << "Xvfb did not start (scripts/setup.sh installs it)";
  ::setenv("DISPLAY", display.display().c_str(), 1);
  // A Flock of Birds on a pseudo-terminal, and a wearer's calibration from mimic calibrate.
  mimic::test::Child flock({mimic::test::mimic_binary(), "sim", "flock", "--birds", "4", "--seed", "3"});
  const std::string pty = flock.line();
  ASSERT_EQ(pty.rfind("/dev/", 0), 0u) << pty;
  const std::string cal = temp("cal.json");
  const Outcome calibrate = run_mimic("calibrate --source 'sim:idle?sensors=6' --out '" + cal +
                                      "' --countdown 0 --seconds 1 --max-motion-cm 10 --max-motion-deg 30");
  ASSERT_EQ(calibrate.status, 0) << calibrate.output;
  const std::string log = mimic::test::repo_test_data("logs/golden_v1.mlog").string();
  const std::string clip = mimic::test::clip_path("07_01");
  const std::vector<std::pair<std::string, size_t>> forms = {
      {"", 1},  // the default: sim:walk
      {"--source sim:walk", 1},
      {"--source 'sim:idle?rate=90&sensors=11&seed=2&noise_mm=2'", 1},
      {"--source 'bvh:" + clip + "?loop=1&sensors=11'", 1},
      {"--source 'replay:" + log + "?loop=1'", 1},
      {"--source 'flock:" + pty + "?birds=4'", 1},
      {"--source vmc:0", 1},
      {"--source sim:walk --calibration '" + cal + "'", 1},
      {"--body preset:child", 1},
      {"--source sim:walk --body preset:child --place 1,2,90 --navigate spacemouse:sim", 1},
      {"--source sim:walk --source 'actor:follow?target=1&seed=4' --source actor:greet --place=-1,-2 "
       "--source 'actor:wander?seed=2' --body preset:child --room 10x6",
       4},
  };
  for (const auto& [form, avatars] : forms) {
    const Outcome run = run_mimic("run --listen 127.0.0.1:0 --duration 0.3 --quiet " + form);
    ASSERT_EQ(run.status, 0) << "mimic run " << form << "\n" << run.output;
    EXPECT_EQ(count_of(run.output, "mimic run: avatar "), avatars) << form << "\n" << run.output;
    const Outcome view = run_mimic("view --frames 3 --no-vsync --no-panel --lod 3 --size 320x240 " + form);
    ASSERT_EQ(view.status, 0) << "mimic view " << form << "\n" << view.output;
    EXPECT_EQ(count_of(view.output, "avatar    avatar"), avatars) << form << "\n" << view.output;
  }
  for (const std::string bad :
       {"--source nope:x", "--source 'sim:walk?brids=4'", "--source sim:walk --place 1", "--source 'actor:dance'",
        "--source sim:walk --navigate 'sim:walk'", "--source sim:walk --body a.json --body b.json"}) {
    EXPECT_EQ(run_mimic("run --listen 127.0.0.1:0 --duration 0.3 --quiet " + bad).status, 2) << "mimic run " << bad;
    EXPECT_EQ(run_mimic("view --frames 1 --no-vsync " + bad).status, 2) << "mimic view " << bad;
  }
  std::filesystem::remove(cal);
}

}  // namespace

}  // namespace view_window_test
