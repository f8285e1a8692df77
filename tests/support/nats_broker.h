// Real nats-server processes for tests: one broker, or a cluster of three, on free loopback
// ports, JetStream on (a temporary store directory), stopped and cleaned up afterwards. Unless
// a test asks for a single user of its own, a broker runs the shipped configuration
// (config/nats/mimic-broker.conf, its users written by scripts/nats_auth_conf.sh): the test
// publishers below and the relay user "relay", each with its permissions, passwords random per
// test process and given to nats-server in its environment as in production.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <random>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "free_port.h"

extern char** environ;

namespace mimic::test {

// A port nobody listens on right now (the kernel's pick for an ephemeral bind).
inline uint16_t free_loopback_port() { return free_port(SOCK_STREAM); }

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

// The users every test broker knows: publishers (their --nats-name) and the relays' user.
inline const std::vector<std::string>& nats_test_publishers() {
  static const std::vector<std::string> names = {"hostA", "hostB", "hostC", "hostK", "hostM",
                                                 "hostT", "hostV", "hostX", "ghost", "mallory"};
  return names;
}
inline constexpr const char* kNatsRelayUser = "relay";

// One random password per user for the whole test process (a broker restarted on the same port
// takes the same ones).
inline std::string nats_test_password(const std::string& user) {
  static std::map<std::string, std::string> passwords;
  static std::mt19937_64 rng{std::random_device{}()};
  auto& p = passwords[user];
  if (p.empty()) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(rng()));
    p = buf;
  }
  return p;
}
// MIMIC_NATS_PASSWORD_<USER>, as scripts/nats_auth_conf.sh names it.
inline std::string nats_password_variable(const std::string& user) {
  std::string v = "MIMIC_NATS_PASSWORD_";
  for (char c : user)
    v += (c >= 'a' && c <= 'z') ? char(c - 'a' + 'A') : ((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9')) ? c : '_';
  return v;
}
// nats://USER:PASSWORD@HOST:PORT for each address of a comma-separated list.
inline std::string nats_url_as(const std::string& urls, const std::string& user) {
  std::string out;
  for (size_t begin = 0; begin < urls.size();) {
    size_t end = urls.find(',', begin);
    if (end == std::string::npos) end = urls.size();
    const std::string u = urls.substr(begin, end - begin);
    const size_t scheme = u.find("://");
    out.append(out.empty() ? "" : ",").append(u.substr(0, scheme + 3)).append(user).append(":");
    out.append(nats_test_password(user)).append("@").append(u.substr(scheme + 3));
    begin = end + 1;
  }
  return out;
}

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
    if (auth.token.empty() && auth.user.empty()) {
      write_shipped_config(c);
    } else {
      c << "listen: 127.0.0.1:" << port << "\n";
      c << "jetstream { store_dir: \"" << dir_ << "/js\" }\n";
      if (!auth.token.empty()) c << "authorization { token: \"" << auth.token << "\" }\n";
      if (!auth.user.empty())
        c << "authorization { user: \"" << auth.user << "\", password: \"" << auth.password << "\" }\n";
    }
    c << "server_name: " << name << "\n";
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
    // The users' passwords, from the environment as the shipped configuration wants them.
    std::vector<std::string> env_text;
    // (nats-server reads a variable's value as a configuration value: quoted, it is a string.)
    for (const auto& u : users()) env_text.push_back(nats_password_variable(u) + "=\"" + nats_test_password(u) + "\"");
    std::vector<char*> envp;
    for (auto& e : env_text) envp.push_back(e.data());
    for (char** e = environ; *e; ++e) envp.push_back(*e);
    envp.push_back(nullptr);
    // Forked rather than spawned, to be tied to this process: a test that crashes takes its
    // brokers with it (they would otherwise run on, retrying their cluster routes, and keep
    // the test's output pipe open, so CTest waits out its whole timeout). The signal comes when
    // the starting thread ends: start brokers on the test's own thread. Between fork and exec
    // only async-signal-safe calls. The broker writes its log to the file; nothing to the pipe.
    const pid_t parent = ::getpid();
    pid_ = ::fork();
    if (pid_ < 0) return false;
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(127);
      if (const int null = ::open("/dev/null", O_RDWR); null >= 0) {
        ::dup2(null, 0);
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
      ::execve(bin.c_str(), argv.data(), envp.data());
      ::_exit(127);
    }
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
  // SIGSTOP/SIGCONT: a node that hangs (its connections open, nothing answered) and comes back.
  void signal(int sig) {
    if (pid_ > 0) ::kill(pid_, sig);
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
  // The address with a user's credentials in it (what MIMIC_NATS_USER/PASSWORD carry in the product).
  std::string url_as(const std::string& user) const { return nats_url_as(url(), user); }
  std::string log() const {
    std::ifstream f(dir_ + "/nats.log");
    return std::string(std::istreambuf_iterator<char>(f), {});
  }

 private:
  static std::vector<std::string> users() {
    std::vector<std::string> u = nats_test_publishers();
    u.push_back(kNatsRelayUser);
    return u;
  }

  // config/nats/mimic-broker.conf with this node's address and store, and the users' file from
  // scripts/nats_auth_conf.sh beside it.
  void write_shipped_config(std::ofstream& c) {
    std::ifstream shipped(std::string(MIMIC_SOURCE_DIR) + "/config/nats/mimic-broker.conf");
    for (std::string line; std::getline(shipped, line);) {
      if (line.starts_with("listen:")) line = "listen: 127.0.0.1:" + std::to_string(port);
      if (const size_t at = line.find("store_dir:"); at != std::string::npos)
        line = line.substr(0, at) + "store_dir: \"" + dir_ + "/js\"";
      c << line << "\n";
    }
    std::vector<std::string> args = {"/bin/sh", std::string(MIMIC_SOURCE_DIR) + "/scripts/nats_auth_conf.sh", "--relay",
                                     kNatsRelayUser};
    for (const auto& p : nats_test_publishers()) {
      args.push_back("--publisher");
      args.push_back(p);
    }
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, (dir_ + "/mimic-auth.conf").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    pid_t pid = -1;
    if (posix_spawn(&pid, "/bin/sh", &fa, nullptr, argv.data(), environ) == 0) ::waitpid(pid, nullptr, 0);
    posix_spawn_file_actions_destroy(&fa);
  }

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
  std::string urls_as(const std::string& user) const { return nats_url_as(urls(), user); }
};

}  // namespace mimic::test
