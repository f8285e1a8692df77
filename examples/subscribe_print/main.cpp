// Subscribes to a Mimic scene and prints every avatar's joint positions, one line per joint
// per frame:   <avatar> <sequence> <joint> <x> <y> <z>   (metres, Mimic's world frame)
//
//   subscribe_print [HOST:PORT] [--frames N]      (default 127.0.0.1:7777, 10 frames)
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <mimic/client.h>

int main(int argc, char** argv) {
  mimic::client::Options options;
  long frames = 10;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc) {
      frames = std::strtol(argv[++i], nullptr, 10);
    } else if (argv[i][0] != '-') {
      options.server = argv[i];
    } else {
      std::fprintf(stderr, "usage: subscribe_print [HOST:PORT] [--frames N]\n");
      return 2;
    }
  }
  std::string error;
  auto sub = mimic::client::Subscriber::connect(options, &error);
  if (!sub) {
    std::fprintf(stderr, "subscribe_print: %s\n", error.c_str());
    return 1;
  }
  std::printf("# libmimic_client %s, connected to %s\n", mimic::client::version(), options.server.c_str());
  long printed = 0;
  sub->on_avatar = [](const mimic::client::Avatar& a) {
    std::printf("# avatar %u '%s': %zu joints, %zu DOFs\n", unsigned(a.id), a.name.c_str(), a.joints.size(),
                a.dof_rad.size());
  };
  sub->on_frame = [&](const mimic::client::Avatar& a) {
    if (printed >= frames) return;
    for (const auto& j : a.joints)
      std::printf("%s %u %s %.4f %.4f %.4f\n", a.name.c_str(), a.sequence, j.name.c_str(), double(j.position_m.x),
                  double(j.position_m.y), double(j.position_m.z));
    ++printed;
  };
  while (printed < frames)
    if (!sub->run_for(0.05, &error)) {
      std::fprintf(stderr, "subscribe_print: %s\n", error.c_str());
      return 1;
    }
  return 0;
}
