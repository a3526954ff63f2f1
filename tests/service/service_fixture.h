#ifndef EXCITE_TESTS_SERVICE_SERVICE_FIXTURE_H_
#define EXCITE_TESTS_SERVICE_SERVICE_FIXTURE_H_

// What the tests of the service over a real loopback server share: a pendulum
// config, a fixture with an in-process server on port 0 and a temporary data
// directory (client library and raw stub), and status checks.

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/excite_client.h"
#include "gmock/gmock.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "grpcpp/create_channel.h"
#include "grpcpp/security/credentials.h"
#include "gtest/gtest.h"
#include "server/service/config_text.h"
#include "server/service/config_validation.h"
#include "server/service/excite_server.h"
#include "tests/service/pendulum_data.h"
#include "tests/support/temp_dir.h"

namespace excite::testing {

inline constexpr char kPendulumConfig[] = R"pb(
  state_dim: 2
  input_dim: 1
  input_bounds { lower: -3 upper: 3 }
  state_bounds { lower: -3.2 upper: 3.2 }
  state_bounds { lower: -8 upper: 8 }
  noise { variance: 1e-6 fit: true }
  kernel { fit: true restarts: 1 max_iterations: 40 }
  strategy: STRATEGY_REC
  horizon: 5
  planner { max_iterations: 30 time_budget_s: 5 }
  seed: 7
)pb";

inline v1::SessionConfig PendulumConfig(v1::Strategy strategy = v1::STRATEGY_REC) {
  absl::StatusOr<v1::SessionConfig> config =
      service::ParseSessionConfigText(kPendulumConfig);
  EXPECT_TRUE(config.ok()) << config.status();
  config->set_strategy(strategy);
  return *config;
}

// Hyperparameters of one pendulum output (z = (theta, omega, u)).
inline v1::Hyperparameters PendulumHyperparameters(double signal_variance,
                                                   std::vector<double> lengthscales,
                                                   double noise_variance = 1e-4) {
  v1::Hyperparameters h;
  h.set_signal_variance(signal_variance);
  for (double l : lengthscales) h.add_lengthscales(l);
  h.set_noise_variance(noise_variance);
  return h;
}

// PendulumConfig() with fixed hyperparameters (no fit), `first` for theta's
// output and `second` for omega's.
inline v1::SessionConfig PendulumFixedKernelConfig(const v1::Hyperparameters& first,
                                                   const v1::Hyperparameters& second) {
  v1::SessionConfig config = PendulumConfig();
  config.mutable_noise()->set_fit(false);
  v1::KernelConfig* kernel = config.mutable_kernel();
  kernel->Clear();
  kernel->set_fit(false);
  *kernel->add_fixed() = first;
  *kernel->add_fixed() = second;
  return config;
}

// A valid archive of `id` built by hand: the pendulum config as validation
// stores it and 10 pendulum samples (no hyperparameters, creation time unknown).
inline v1::SessionArchive PendulumArchive(const std::string& id) {
  v1::SessionArchive archive;
  archive.set_format_version(1);
  archive.set_session_id(id);
  absl::StatusOr<v1::SessionConfig> config =
      service::ValidatedSessionConfig(PendulumConfig(), "config");
  EXPECT_TRUE(config.ok()) << config.status();
  *archive.mutable_config() = *config;
  for (const v1::Transition& t : PendulumTransitions(10, 0, 5)) {
    *archive.add_samples() = t;
  }
  return archive;
}

// A server started in SetUp with options_ (tests may change options_ and call
// StopServer() / StartServer() to restart on the same data directory).
class ServiceTest : public ::testing::Test {
 protected:
  ServiceTest() {
    options_.listen = "127.0.0.1:0";
    options_.data_dir = tmp_.path() + "/data";
    options_.limits.max_samples_per_session = 500;
  }
  void SetUp() override { StartServer(); }
  void TearDown() override { StopServer(); }

  void StartServer() {
    absl::StatusOr<std::unique_ptr<service::ExciteServer>> server =
        service::ExciteServer::Start(options_);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    ASSERT_GT(server_->port(), 0);
    client_ = client::ExciteClient::Connect(server_->address());
    ASSERT_TRUE(client_->WaitForReady(std::chrono::seconds(5)).ok());
    stub_ = v1::ExplorationService::NewStub(
        grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials()));
  }

  void StopServer() {
    stub_.reset();
    client_.reset();
    server_.reset();  // shuts down and closes the store
  }

  v1::Session Create(const std::string& id,
                     const v1::SessionConfig& config = PendulumConfig()) {
    absl::StatusOr<v1::Session> session = client_->CreateSession(config, id);
    EXPECT_TRUE(session.ok()) << session.status();
    return session.ok() ? *session : v1::Session();
  }

  v1::AddDataResponse Add(const std::string& name,
                          const std::vector<std::vector<v1::Transition>>& batches) {
    absl::StatusOr<v1::AddDataResponse> response = client_->AddData(name, batches);
    EXPECT_TRUE(response.ok()) << response.status();
    return response.ok() ? *response : v1::AddDataResponse();
  }

  // ListSessions (every page), and GetSession and ExportSession of each listed
  // session, all succeed; returns the number listed.
  int ExpectEveryReadSucceeds() {
    int listed = 0;
    std::string token;
    do {
      absl::StatusOr<v1::ListSessionsResponse> page = client_->ListSessions(0, token);
      EXPECT_TRUE(page.ok()) << page.status();
      if (!page.ok()) return -1;
      for (const v1::Session& session : page->sessions()) {
        ++listed;
        absl::StatusOr<v1::Session> got = client_->GetSession(session.name());
        EXPECT_TRUE(got.ok()) << session.name() << ": " << got.status();
        absl::StatusOr<v1::SessionArchive> exported =
            client_->ExportSession(session.name());
        EXPECT_TRUE(exported.ok()) << session.name() << ": " << exported.status();
      }
      token = page->next_page_token();
    } while (!token.empty());
    return listed;
  }

  // A raw AddData stream of `messages`.
  grpc::Status RawAddData(const std::vector<v1::AddDataRequest>& messages,
                          v1::AddDataResponse* response) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    auto writer = stub_->AddData(&context, response);
    for (const v1::AddDataRequest& m : messages) {
      if (!writer->Write(m)) break;
    }
    writer->WritesDone();
    return writer->Finish();
  }

  TempDir tmp_;
  service::ServerOptions options_;
  std::unique_ptr<service::ExciteServer> server_;
  std::unique_ptr<client::ExciteClient> client_;
  std::unique_ptr<v1::ExplorationService::Stub> stub_;
};

inline void ExpectStatus(const absl::Status& status, absl::StatusCode code,
                         const std::string& message_part) {
  EXPECT_EQ(status.code(), code) << status;
  EXPECT_THAT(std::string(status.message()), ::testing::HasSubstr(message_part))
      << status;
}

// The hyperparameters of each output of `actual` and `expected` agree to a
// relative 1e-9.
inline void ExpectSameHyperparameters(const v1::Session& actual,
                                      const v1::Session& expected) {
  ASSERT_EQ(actual.outputs_size(), expected.outputs_size());
  for (int i = 0; i < expected.outputs_size(); ++i) {
    const v1::Hyperparameters& a = expected.outputs(i).hyperparameters();
    const v1::Hyperparameters& b = actual.outputs(i).hyperparameters();
    EXPECT_NEAR(b.signal_variance(), a.signal_variance(), 1e-9 * a.signal_variance());
    EXPECT_NEAR(b.noise_variance(), a.noise_variance(), 1e-9 * a.noise_variance());
    ASSERT_EQ(b.lengthscales_size(), a.lengthscales_size());
    for (int l = 0; l < a.lengthscales_size(); ++l) {
      EXPECT_NEAR(b.lengthscales(l), a.lengthscales(l), 1e-9 * a.lengthscales(l));
    }
  }
}

// google.rpc.BadRequest for the validation failure, parsed from the binary
// error details (grpc-status-details-bin) of a raw gRPC call.
inline google::rpc::BadRequest BadRequestOf(const grpc::Status& status) {
  google::rpc::Status details;
  google::rpc::BadRequest bad_request;
  EXPECT_FALSE(status.error_details().empty()) << status.error_message();
  EXPECT_TRUE(details.ParseFromString(status.error_details()));
  EXPECT_EQ(details.code(), static_cast<int>(status.error_code()));
  EXPECT_EQ(details.message(), status.error_message());
  EXPECT_EQ(details.details_size(), 1);
  if (details.details_size() == 1) {
    EXPECT_TRUE(details.details(0).UnpackTo(&bad_request));
  }
  return bad_request;
}

}  // namespace excite::testing

#endif  // EXCITE_TESTS_SERVICE_SERVICE_FIXTURE_H_
