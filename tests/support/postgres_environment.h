#ifndef EXCITE_TESTS_SUPPORT_POSTGRES_ENVIRONMENT_H_
#define EXCITE_TESTS_SUPPORT_POSTGRES_ENVIRONMENT_H_

#include <atomic>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "tests/support/postgres_server.h"

namespace excite::testing {

// One PostgreSQL server for a whole test binary (started before the first test,
// stopped after the last), and a fresh database per test. Register it once per
// binary: `const auto* const kPostgres = PostgresEnvironment::Register();`.
class PostgresEnvironment : public ::testing::Environment {
 public:
  static const PostgresEnvironment* Register() {
    return static_cast<const PostgresEnvironment*>(
        ::testing::AddGlobalTestEnvironment(new PostgresEnvironment));
  }

  void SetUp() override {
    absl::StatusOr<std::unique_ptr<PostgresServer>> started = PostgresServer::Start();
    ASSERT_TRUE(started.ok()) << started.status();
    server_ = *std::move(started);
  }
  void TearDown() override { server_.reset(); }

  // The binary's server (null if it did not start: SetUp failed the test run).
  static PostgresServer* server() { return server_.get(); }

  // A new empty database named `prefix`_N; "" (and a test failure) if it cannot
  // be made.
  static std::string NewDatabase(const std::string& prefix) {
    static std::atomic<int> next{0};
    if (server_ == nullptr) {
      ADD_FAILURE() << "no PostgreSQL server";
      return "";
    }
    const std::string name = absl::StrCat(prefix, "_", next++);
    absl::Status created = server_->CreateDatabase(name);
    EXPECT_TRUE(created.ok()) << created;
    return created.ok() ? name : "";
  }

 private:
  static inline std::unique_ptr<PostgresServer> server_;
};

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SUPPORT_POSTGRES_ENVIRONMENT_H_
