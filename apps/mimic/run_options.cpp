#include "run_options.h"

#include <cmath>
#include <cstdlib>

#include "lean_flags.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/service/pipeline.h"
#include "source_args.h"

namespace mimic::app {

const char* const kRunAbout =
    "Runs the realtime pipeline (read -> solve -> deform -> encode -> send) and serves the avatars\n"
    "to subscribers (mimic subscribe, VR scenes). With no arguments: simulated trackers on the\n"
    "built-in walk, the default body, serving on 127.0.0.1:7777. Watch it with\n"
    "`mimic view --connect 127.0.0.1:7777` (every avatar, deformed in the viewer).\n"
    "--body, --place, --navigate and --calibration belong to the --source before them (before\n"
    "any --source: to the default source, sim:walk); each at most once per source.";

namespace {

constexpr const char* kFooter =
    "sources (--source SPEC; default sim:walk):\n"
    "  sim:walk | sim:idle?rate=90&sensors=11&seed=2   simulated trackers on a built-in motion\n"
    "  actor:wander | actor:follow?target=K | actor:greet   an autonomous actor walking the room\n"
    "                                  (avoids the others, stays inside; seed=N)\n"
    "  Hardware and other programs (docs/hardware.md):\n"
    "  flock:/dev/ttyUSB0?birds=4      a Flock of Birds on RS-232\n"
    "  vrpn:Tracker0@host?layout=6     a VRPN tracker (OptiTrack, Vicon, Polhemus/ART/Vive via\n"
    "                                  vrpn_server)\n"
    "  vmc:39539                       VMC performer data on UDP (SlimeVR, mocopi, VSeeFace,\n"
    "                                  mimic run --vmc)\n"
    "  osc-trackers:9000               VRChat-style OSC trackers (SlimeVR)\n"
    "  replay:session.mlog             a recorded session\n"
    "\n"
    "examples:\n"
    "  mimic run --source sim:walk --source actor:wander --place 2,0\n"
    "  mimic run --source flock:/dev/ttyUSB0?birds=6 --body me.json --calibration me-cal.json\n"
    "  mimic run --listen 0.0.0.0:7777   (with MIMIC_SECRET set in the environment)\n"
    "\n"
    "The first line on stdout says where the scene is served: 'serving on ADDR:PORT'. The live\n"
    "status line (stderr) shows fps, subscribers, dropped and rejected frames and p50/p99 of each\n"
    "stage in microseconds. Ctrl-C stops cleanly.\n"
    "\n"
    "exit status: 0 stopped (Ctrl-C, --duration, the remote scene ended), 1 failure (a source or\n"
    "port that does not open), 2 usage error";

// "WxD" in metres, as service::parse_room takes it.
CLI::Validator room_check() {
  return CLI::Validator(
      [](std::string& input) -> std::string {
        service::Room room;
        return service::parse_room(input, room) ? std::string()
                                                : "must be WxD in metres (2..100 each), got '" + input + "'";
      },
      "WxD");
}

// The --source groups and the scene they make.
void add_scene_options(cli::Parser& p, cli::OptionGroups& sources, RunOptions& o) {
  sources
      .member("--body",
              "body model of the avatar of the --source before it (default body\n"
              "otherwise), or preset:NAME (mimic scale --list); sent once to every\n"
              "subscriber as it joins. Its source is solved on the body's skeleton")
      ->type_name("FILE");
  sources
      .member("--place",
              "where that --source stands in the room (metres, heading in degrees;\n"
              "default: the avatars side by side along X, 1.5 m apart)")
      ->type_name("X,Z[,DEG]");
  sources
      .member("--navigate",
              "move that --source's avatar through the room with a 6-DOF device:\n"
              "spaceball:PATH, magellan:PATH, spacemouse[:sim] (?speed=M/S at full push,\n"
              "default 1.2; turn=RAD/S, 1.6; dead=dead zone, 0.08)")
      ->type_name("SPEC");
  sources
      .member("--calibration",
              "sensor calibration of that --source (from mimic calibrate): the wearer's\n"
              "fitted skeleton and sensor offsets. Without it, simulated sources use\n"
              "their exact mounts, trackers the standard layout's placements")
      ->type_name("FILE");
  p->add_option_function<std::string>(
       "--room", [&o](const std::string& text) { service::parse_room(text, o.scene.room); },
       "the room's size in metres (default 8x8), centred on the origin")
      ->check(room_check());
  p->add_option("--mesh-lod", o.scene.mesh_lod,
                "skin level of detail deformed every frame and offered as mesh frames to\n"
                "thin clients (mimic subscribe --mesh-lod L): 0 the body's own contours\n"
                "(finest) to 3 (438 triangles)")
      ->check(CLI::Range(0, service::kMeshLodCount - 1));
  p->add_option_function<std::string>(
       "--mesh-method", [&o](const std::string& name) { o.scene.skin_method = *avatar::parse_skin_method(name); },
       "realtime (default): contours measured once, moved with the joints (muscles\n"
       "kept); full: every contour ray-cast every frame")
      ->check(cli::parsed_by(avatar::parse_skin_method, "realtime|full"));
}

// Where the avatars go: a server here or a remote scene, and the other outputs.
CLI::Option* add_output_options(cli::Parser& p, RunOptions& o) {
  o.server.listen = "127.0.0.1:7777";
  p->add_option("--listen", o.server.listen,
                "where to serve (port 0 picks one; localhost is 127.0.0.1). Any\n"
                "non-loopback address requires --secret. Subscribers may take their pose\n"
                "frames as UDP datagrams from the same port (mimic subscribe --udp)")
      ->type_name("ADDR:PORT");
  p->add_flag_function(
      "--no-udp", [&o](std::int64_t) { o.server.udp = false; },
      "frames over TCP only (no UDP socket; subscribers asking for UDP are told\n"
      "so in the handshake and get their frames on the stream)");
  add_lean_flags(p.app(), o.server);
  p->add_option("--secret", o.server.secret,
                "shared secret publishers must present. On the command line it shows in\n"
                "'ps' to every user of this machine: prefer the MIMIC_SECRET environment\n"
                "variable")
      ->type_name("S");
  auto* publish = p->add_option("--publish", o.publish, "do not host: publish the avatars into the scene served there")
                      ->type_name("HOST:PORT");
  for (const char* lean : {"--lean-shift", "--lean-key-interval"}) p->get_option(lean)->excludes(publish);
  p->add_option("--vmc", o.vmc,
                "also send every avatar as VMC (OSC over UDP), e.g. 127.0.0.1:39539; avatar\n"
                "i (counting from 0) goes to PORT + i")
      ->type_name("HOST:PORT");
  p->add_option("--vrpn", o.vrpn,
                "also serve every avatar as VRPN trackers (VRPN 07.35 over TCP + UDP;\n"
                "docs/vrpn.md): Avatar<i>, one sensor per joint, and Sensors<i>, its\n"
                "tracker samples; e.g. vrpn_print_devices Avatar0@localhost:3883. HOST\n"
                "defaults to 127.0.0.1")
      ->type_name("[HOST:]PORT");
  p->add_option("--http", o.http,
                "also serve the browser viewer (docs/browser.md): a page showing every\n"
                "avatar, deformed in the browser from the lean pose stream, with an Enter\n"
                "VR button (WebXR). HOST defaults to 127.0.0.1; port 0 picks one")
      ->type_name("[HOST:]PORT")
      ->excludes(publish);
  return publish;
}

// 0 (never) or kMinModelTtl_s..kMaxModelTtl_s seconds.
#if MIMIC_HAVE_NATS
CLI::Validator model_ttl_check() {
  return CLI::Validator(
      [](std::string& input) -> std::string {
        double s = -1;
        const bool ok =
            CLI::detail::lexical_cast(input, s) && (s == 0 || (s >= net::kMinModelTtl_s && s <= net::kMaxModelTtl_s));
        return ok ? std::string() : "must be 0 (never) or 3 to 86400 seconds, got '" + input + "'";
      },
      "FLOAT 0 or in [3 - 86400]");
}
#endif

// --nats and the options that only make sense with it. Without the broker transport --nats is
// still taken (not shown) so that the refusal says why.
void add_nats_options(cli::Parser& p, CLI::Option* publish, RunOptions& o) {
#if MIMIC_HAVE_NATS
  auto* nats = p->add_option("--nats", o.nats,
                             "also publish every avatar through the NATS broker(s) nats://HOST:PORT\n"
                             "(docs/scaling.md): models latest-wins in the scene's key-value bucket,\n"
                             "each pass's pose frames in one message on mimic.SCENE.poses.NAME. Local\n"
                             "listeners are served as usual; a broker that is down is joined when it\n"
                             "comes up. Credentials from MIMIC_NATS_USER + MIMIC_NATS_PASSWORD, or\n"
                             "MIMIC_NATS_TOKEN")
                   ->type_name("URL[,URL]")
                   ->excludes(publish);
  net::NatsOptions& no = o.nats_options;
  no.name.clear();  // the host name, found when it is needed
  p->add_option("--scene", no.scene, "the scene on the broker (default 'default'; A-Z a-z 0-9 _ -)")
      ->type_name("NAME")
      ->default_str("")
      ->needs(nats);
  p->add_option("--nats-name", no.name,
                "this publisher's name (default: the host name); with the avatar's name it\n"
                "makes the avatar's key, the same on every restart. Two processes on one\n"
                "host publishing into one scene need different names")
      ->type_name("N")
      ->needs(nats);
  p->add_option("--nats-model-ttl", no.model_ttl_s,
                "when this publisher creates the scene's bucket: a model not put again for\n"
                "S seconds leaves it (0: never). A live publisher puts its models again\n"
                "every S/3 s, so only a crashed one's expire; relays drop a crashed\n"
                "publisher's avatars after 3 missed heartbeats (one a second) anyway")
      ->check(model_ttl_check())
      ->needs(nats);
  p->add_option("--nats-mesh-hz", no.mesh_max_hz,
                "mesh frames per avatar per second at most, sent at the --mesh-lod only\n"
                "while a relay with mesh viewers at that LOD asks for them")
      ->check(cli::finite_range(net::kMinMeshHz, net::kMaxMeshHz))
      ->needs(nats);
#else
  p->add_option("--nats", o.nats, "")->group("")->excludes(publish);
#endif
}

}  // namespace

std::optional<int> parse_run_options(cli::Parser& p, const std::vector<std::string>& argv, RunOptions& o) {
  p->footer(kFooter);
  // Read once, right after the parse: `p` is not parsed again after this returns.
  cli::OptionGroups sources(p.app(), "--source",
                            "tracker source of one avatar; repeat for several avatars (the forms\n"
                            "below; default sim:walk)",
                            "sim:walk");
  add_scene_options(p, sources, o);
  CLI::Option* publish = add_output_options(p, o);
  add_nats_options(p, publish, o);
  p->add_option("--duration", o.duration_s, "stop by itself after S seconds (default: run until Ctrl-C)")
      ->default_str("")
      ->check(cli::finite_range(0, INFINITY));
  p->add_option("--realtime", o.rt_priority,
                "run the loop at SCHED_FIFO priority PRIO (1-99; needs CAP_SYS_NICE), so a\n"
                "busy machine does not delay frames, and keep the CPUs out of deep idle states\n"
                "while it runs (/dev/cpu_dma_latency, needs root), so an idle one wakes at once")
      ->type_name("PRIO")
      ->default_str("")
      ->check(CLI::Range(0L, 99L));
  p->add_flag("--json", o.json,
              "print a JSON summary (stage timings p50/p99 in microseconds, frames, fps,\n"
              "loop_allocations, server counters) on stdout at exit; the same line is\n"
              "printed whenever the process receives SIGUSR1");
  p->add_flag("--quiet", o.quiet, "no live status line on stderr");
  if (auto exit_code = p.parse(argv)) return exit_code;
  service::SourceEntry defaults;
  if (std::string e = sources_from_groups(sources.groups(), {}, o.scene.sources, defaults); !e.empty())
    return p.usage_error(e);
  o.publishing = p->count("--publish") > 0;
  o.vmc_out = p->count("--vmc") > 0;
  o.vrpn_out = p->count("--vrpn") > 0;
  o.nats_out = p->count("--nats") > 0;
  o.http_out = p->count("--http") > 0;
  if (o.http_out && o.http.find(':') == std::string::npos) o.http = "127.0.0.1:" + o.http;
  if (o.server.secret.empty())
    if (const char* env = std::getenv("MIMIC_SECRET")) o.server.secret = env;
#if !MIMIC_HAVE_NATS
  if (o.nats_out) return p.failure("this build has no NATS support (configure with -DMIMIC_WITH_NATS=ON)");
#endif
  return std::nullopt;
}

}  // namespace mimic::app
