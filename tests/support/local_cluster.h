#ifndef EXCITE_TESTS_SUPPORT_LOCAL_CLUSTER_H_
#define EXCITE_TESTS_SUPPORT_LOCAL_CLUSTER_H_

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tests/support/child_process.h"
#include "tests/support/postgres_server.h"

namespace excite::testing {

struct LocalClusterOptions {
  int replicas = 3;
  // The excite-server executable and deploy/haproxy/haproxy.cfg.
  std::string server_binary;
  std::string haproxy_config;
  std::string haproxy_binary = "/usr/sbin/haproxy";
  std::chrono::milliseconds lease_ttl{5000};
  // More flags for every replica (e.g. --log_level=debug).
  std::vector<std::string> server_flags;
  // Where the logs go; empty: a new temporary directory (kept on failure is the
  // caller's choice: it is removed with the cluster).
  std::string dir;
};

// What deploy/compose.scale.yaml runs, as processes on 127.0.0.1: a real
// PostgreSQL server (PostgresServer), N excite-server replicas on it
// (--store=postgresql://..., --replica_id=replica-I, fixed ports), and HAProxy
// with deploy/haproxy/haproxy.cfg whose bind and server lines are rewritten for
// these ports. For the replica fault tests and excite-load --replicas.
class LocalCluster {
 public:
  // Starts everything and waits until the proxy answers ListSessions.
  static absl::StatusOr<std::unique_ptr<LocalCluster>> Start(LocalClusterOptions options);
  ~LocalCluster();

  std::string proxy_address() const;
  std::string replica_address(int i) const;
  static std::string replica_id(int i);
  int replicas() const { return static_cast<int>(replicas_.size()); }
  PostgresServer& postgres() { return *postgres_; }
  // Null after KillReplica.
  ChildProcess* replica(int i) { return replicas_[static_cast<size_t>(i)].get(); }
  // SIGKILL and reap.
  void KillReplica(int i);
  // Starts replica i again (same port and id), waits until it listens.
  absl::Status StartReplica(int i);
  // The replica logs and HAProxy's, for failure messages.
  std::string Logs() const;
  const std::string& dir() const { return dir_; }

 private:
  LocalCluster() = default;
  absl::Status StartProxy();

  LocalClusterOptions options_;
  std::string dir_;
  bool own_dir_ = false;
  std::unique_ptr<PostgresServer> postgres_;
  std::string password_file_;
  std::vector<int> ports_;
  std::vector<std::unique_ptr<ChildProcess>> replicas_;
  int proxy_port_ = 0;
  std::unique_ptr<ChildProcess> proxy_;
};

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SUPPORT_LOCAL_CLUSTER_H_
