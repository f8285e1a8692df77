// Real nats-server processes for tests: one broker, or a cluster of three, on free loopback
// ports, JetStream on (a temporary store directory), stopped and cleaned up afterwards.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace mimic::test {

// A port nobody listens on right now (the kernel's pick for an ephemeral bind).
inline uint16_t free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t n = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
  ::close(fd);
  return ntohs(a.sin_port);
}

inline bool port_accepts(uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

inline std::string nats_server_binary() {
  for (const char* p : {"/usr/bin/nats-server", "/usr/local/bin/nats-server", "/usr/sbin/nats-server"})
    if (::access(p, X_OK) == 0) return p;
  return {};
}

struct NatsAuth {
  std::string user, password, token;
};

class NatsBroker {
 public:
  uint16_t port = 0, cluster_port = 0;
  std::string name;

  NatsBroker() = default;
  NatsBroker(const NatsBroker&) = delete;
  NatsBroker& operator=(const NatsBroker&) = delete;
  ~NatsBroker() {
    kill();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  // Writes the configuration; `routes` are the other nodes' cluster ports (a cluster when not
  // empty). Ports are chosen here unless set before.
  void configure(const std::string& node_name, const NatsAuth& auth = {}, const std::vector<uint16_t>& routes = {}) {
    name = node_name;
    if (port == 0) port = free_loopback_port();
    char tmpl[] = "/tmp/mimic-nats-XXXXXX";
    dir_ = ::mkdtemp(tmpl);
    std::ofstream c(dir_ + "/nats.conf");
    c << "server_name: " << name << "\nlisten: 127.0.0.1:" << port << "\n";
    c << "jetstream { store_dir: \"" << dir_ << "/js\" }\n";
    if (!auth.token.empty()) c << "authorization { token: \"" << auth.token << "\" }\n";
    if (!auth.user.empty()) c << "authorization { user: \"" << auth.user << "\", password: \"" << auth.password << "\" }\n";
    if (cluster_port) {
      c << "cluster { name: mimic_test, listen: 127.0.0.1:" << cluster_port << ", routes: [";
      for (size_t i = 0; i < routes.size(); ++i) c << (i ? ", " : "") << "nats-route://127.0.0.1:" << routes[i];
      c << "] }\n";
    }
  }

  // Starts the process and waits until it accepts clients (false after `timeout_s`).
  bool start(double timeout_s = 10) {
    const std::string bin = nats_server_binary();
    if (bin.empty()) return false;
    const std::string conf = dir_ + "/nats.conf", log = dir_ + "/nats.log";
    std::vector<std::string> args = {bin, "-c", conf, "-l", log};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, bin.c_str(), nullptr, nullptr, argv.data(), environ) != 0) return false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      if (port_accepts(port)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  // SIGKILL: the node is gone at once, as on a crash.
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  bool running() const { return pid_ > 0; }
  // CPU time the broker process has used (user + system), for figures.
  double cpu_seconds() const {
    std::ifstream f("/proc/" + std::to_string(pid_) + "/stat");
    std::string text((std::istreambuf_iterator<char>(f)), {});
    const size_t close = text.rfind(')');
    if (close == std::string::npos) return 0;
    std::istringstream rest(text.substr(close + 2));
    std::string field;
    unsigned long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stoull(field);
      if (i == 15) stime = std::stoull(field);
    }
    return double(utime + stime) / double(::sysconf(_SC_CLK_TCK));
  }
  std::string url() const { return "nats://127.0.0.1:" + std::to_string(port); }
  std::string log() const {
    std::ifstream f(dir_ + "/nats.log");
    return std::string(std::istreambuf_iterator<char>(f), {});
  }

 private:
  pid_t pid_ = -1;
  std::string dir_;
};

// Three nodes routed to each other, JetStream clustered. `urls()` lists all three.
class NatsCluster {
 public:
  NatsBroker nodes[3];
  bool start(const NatsAuth& auth = {}) {
    for (auto& n : nodes) {
      n.port = free_loopback_port();
      n.cluster_port = free_loopback_port();
    }
    for (int i = 0; i < 3; ++i) {
      std::vector<uint16_t> routes;
      for (int j = 0; j < 3; ++j)
        if (j != i) routes.push_back(nodes[j].cluster_port);
      std::string node = "n";  // appended: GCC 12 warns falsely on "literal" + string (-Wrestrict)
      node.append(std::to_string(i + 1));
      nodes[i].configure(node, auth, routes);
    }
    for (auto& n : nodes)
      if (!n.start()) return false;
    return true;
  }
  std::string urls() const { return nodes[0].url() + "," + nodes[1].url() + "," + nodes[2].url(); }
};

}  // namespace mimic::test
