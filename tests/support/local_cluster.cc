#include "tests/support/local_cluster.h"

#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/excite_client.h"

namespace excite::testing {
namespace {

using Clock = std::chrono::steady_clock;

// `template_text` (deploy/haproxy/haproxy.cfg) with the frontend bound to
// 127.0.0.1:`port` and the backend's servers replaced by `servers` (host:port,
// named replica-I); the DNS resolvers section and options go (fixed addresses).
std::string HaproxyConfigFor(const std::string& template_text, int port,
                             const std::vector<std::string>& servers) {
  std::ostringstream out;
  bool in_resolvers = false;
  for (absl::string_view line : absl::StrSplit(template_text, '\n')) {
    const std::string trimmed(absl::StripLeadingAsciiWhitespace(line));
    if (absl::StartsWith(line, "resolvers ")) {
      in_resolvers = true;
      continue;
    }
    if (in_resolvers) {
      if (!trimmed.empty() && absl::StartsWith(line, "  ")) continue;
      in_resolvers = false;
    }
    if (absl::StartsWith(trimmed, "bind ")) {
      out << "  bind 127.0.0.1:" << port << " proto h2\n";
    } else if (absl::StartsWith(trimmed, "server ")) {
      continue;
    } else if (absl::StartsWith(trimmed, "default-server ")) {
      std::string options(line);
      const size_t resolvers = options.find(" resolvers ");
      if (resolvers != std::string::npos) options.resize(resolvers);
      out << options << "\n";
      for (size_t i = 0; i < servers.size(); ++i) {
        out << "  server " << LocalCluster::replica_id(static_cast<int>(i)) << " "
            << servers[i] << "\n";
      }
    } else {
      out << line << "\n";
    }
  }
  return out.str();
}

// Waits until `log` says the server listens (or the process ended).
absl::Status WaitListening(ChildProcess& process, std::chrono::seconds timeout) {
  const Clock::time_point end = Clock::now() + timeout;
  while (Clock::now() < end) {
    if (absl::StrContains(process.Log(), "excite-server listening on")) {
      return absl::OkStatus();
    }
    if (!process.running()) {
      return absl::InternalError(absl::StrCat("excite-server exited:\n", process.Log()));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return absl::DeadlineExceededError(
      absl::StrCat("excite-server did not listen in time:\n", process.Log()));
}

}  // namespace

absl::StatusOr<std::unique_ptr<LocalCluster>> LocalCluster::Start(
    LocalClusterOptions options) {
  std::unique_ptr<LocalCluster> cluster(new LocalCluster());
  cluster->options_ = options;
  if (options.dir.empty()) {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base != nullptr && *base != '\0' ? base : "/tmp") +
                          "/excite-cluster-XXXXXX";
    if (mkdtemp(pattern.data()) == nullptr) {
      return absl::InternalError("cannot create a temporary directory");
    }
    cluster->dir_ = pattern;
    cluster->own_dir_ = true;
  } else {
    cluster->dir_ = options.dir;
    std::filesystem::create_directories(cluster->dir_);
  }
  absl::StatusOr<std::unique_ptr<PostgresServer>> postgres = PostgresServer::Start();
  if (!postgres.ok()) return postgres.status();
  cluster->postgres_ = *std::move(postgres);
  if (absl::Status s = cluster->postgres_->CreateDatabase("cluster"); !s.ok()) return s;
  cluster->password_file_ = cluster->dir_ + "/store-password";
  { std::ofstream(cluster->password_file_) << cluster->postgres_->password() << "\n"; }
  ::chmod(cluster->password_file_.c_str(), 0600);
  for (int i = 0; i < options.replicas; ++i) {
    cluster->ports_.push_back(FreeLoopbackPort());
    cluster->replicas_.emplace_back();
  }
  for (int i = 0; i < options.replicas; ++i) {
    if (absl::Status s = cluster->StartReplica(i); !s.ok()) return s;
  }
  if (absl::Status s = cluster->StartProxy(); !s.ok()) return s;
  return cluster;
}

LocalCluster::~LocalCluster() {
  proxy_.reset();
  replicas_.clear();
  postgres_.reset();
  if (own_dir_) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
}

std::string LocalCluster::replica_id(int i) { return absl::StrCat("replica-", i); }

std::string LocalCluster::proxy_address() const {
  return absl::StrCat("127.0.0.1:", proxy_port_);
}

std::string LocalCluster::replica_address(int i) const {
  return absl::StrCat("127.0.0.1:", ports_[static_cast<size_t>(i)]);
}

void LocalCluster::KillReplica(int i) {
  std::unique_ptr<ChildProcess>& replica = replicas_[static_cast<size_t>(i)];
  if (replica == nullptr) return;
  replica->Signal(SIGKILL);
  replica->Wait(std::chrono::seconds(10));
  replica.reset();
}

absl::Status LocalCluster::StartReplica(int i) {
  std::vector<std::string> argv = {
      options_.server_binary,
      absl::StrCat("--listen=", replica_address(i)),
      absl::StrCat("--store=", postgres_->url("cluster")),
      absl::StrCat("--store_password_file=", password_file_),
      absl::StrCat("--replica_id=", replica_id(i)),
      absl::StrCat("--lease_ttl_ms=", options_.lease_ttl.count()),
  };
  argv.insert(argv.end(), options_.server_flags.begin(), options_.server_flags.end());
  auto process = std::make_unique<ChildProcess>(
      argv, absl::StrCat(dir_, "/", replica_id(i), ".log"));
  if (absl::Status s = WaitListening(*process, std::chrono::seconds(60)); !s.ok()) {
    return s;
  }
  replicas_[static_cast<size_t>(i)] = std::move(process);
  return absl::OkStatus();
}

absl::Status LocalCluster::StartProxy() {
  std::ifstream in(options_.haproxy_config);
  if (!in) return absl::FailedPreconditionError("cannot read " + options_.haproxy_config);
  std::stringstream text;
  text << in.rdbuf();
  std::vector<std::string> servers;
  for (int i = 0; i < replicas(); ++i) servers.push_back(replica_address(i));
  proxy_port_ = FreeLoopbackPort();
  const std::string config = dir_ + "/haproxy.cfg";
  { std::ofstream(config) << HaproxyConfigFor(text.str(), proxy_port_, servers); }
  proxy_ = std::make_unique<ChildProcess>(
      std::vector<std::string>{options_.haproxy_binary, "-db", "-f", config},
      dir_ + "/haproxy.log");
  // Ready once a call goes through to a replica.
  std::unique_ptr<client::ExciteClient> probe =
      client::ExciteClient::Connect(proxy_address());
  const Clock::time_point end = Clock::now() + std::chrono::seconds(30);
  absl::Status last;
  while (Clock::now() < end) {
    last = probe->ListSessions(1, "").status();
    if (last.ok()) return last;
    if (!proxy_->running()) {
      return absl::InternalError(absl::StrCat("haproxy exited:\n", proxy_->Log()));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return absl::DeadlineExceededError(
      absl::StrCat("the proxy did not answer: ", last.ToString(), "\n", proxy_->Log()));
}

std::string LocalCluster::Logs() const {
  std::string all;
  for (size_t i = 0; i < replicas_.size(); ++i) {
    std::ifstream in(absl::StrCat(dir_, "/", replica_id(static_cast<int>(i)), ".log"));
    std::stringstream text;
    text << in.rdbuf();
    std::string log = text.str();
    if (log.size() > 4000) log = log.substr(log.size() - 4000);
    absl::StrAppend(&all, "--- ", replica_id(static_cast<int>(i)), "\n", log);
  }
  if (proxy_ != nullptr) {
    std::string log = proxy_->Log();
    if (log.size() > 4000) log = log.substr(log.size() - 4000);
    absl::StrAppend(&all, "--- haproxy\n", log);
  }
  return all;
}

}  // namespace excite::testing
