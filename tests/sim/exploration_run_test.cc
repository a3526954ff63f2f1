// RunExploration against an in-process fake ExplorationService (no GP, no planner):
// checks the loop's protocol — random steps before min_samples, apply_count, input
// clipping, sequence numbers, AddData batches split at evaluation points, RMSE
// schedule, session deletion — independently of the real server.

#include "sim/exploration_run.h"

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "excite/v1/exploration_service.grpc.pb.h"
#include "sim/plants/pendulum.h"
#include "sim/plants/plant_factory.h"
#include "sim/sim_config.h"

namespace excite::sim {
namespace {

// Plans `planned_input` for every step; predicts x (no change) until
// `exact_after` samples, then the true pendulum step.
class FakeService final : public v1::ExplorationService::Service {
 public:
  explicit FakeService(const Plant* plant) : plant_(plant) {}

  grpc::Status CreateSession(grpc::ServerContext*,
                             const v1::CreateSessionRequest* request,
                             v1::Session* reply) override {
    std::lock_guard<std::mutex> lock(mu_);
    config_ = request->config();
    reply->set_name("sessions/fake");
    *reply->mutable_config() = config_;
    return grpc::Status::OK;
  }
  grpc::Status DeleteSession(grpc::ServerContext*,
                             const v1::DeleteSessionRequest* request,
                             v1::DeleteSessionResponse*) override {
    std::lock_guard<std::mutex> lock(mu_);
    deleted_.push_back(request->name());
    return grpc::Status::OK;
  }
  // Stores each sequence number once (a resent one counts as a duplicate), as
  // the real service does.
  grpc::Status AddData(grpc::ServerContext* context,
                       grpc::ServerReader<v1::AddDataRequest>* reader,
                       v1::AddDataResponse* reply) override {
    v1::AddDataRequest request;
    bool stall = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      int64_t stored = 0;
      int64_t duplicates = 0;
      while (reader->Read(&request)) {
        batch_sizes_.push_back(request.transitions_size());
        for (const v1::Transition& t : request.transitions()) {
          if (!sequences_.insert(t.sequence()).second) {
            ++duplicates;
            continue;
          }
          transitions_.push_back(t);
          ++stored;
        }
      }
      reply->set_stored(stored);
      reply->set_duplicates(duplicates);
      reply->set_sample_count(static_cast<int64_t>(transitions_.size()));
      stall = static_cast<int>(transitions_.size()) == stall_after_storing && stored > 0;
    }
    // Stored, but the answer never comes: a replica that died after its commit
    // behind a proxy that kept the call open.
    while (stall && !context->IsCancelled()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return grpc::Status::OK;
  }
  grpc::Status Predict(grpc::ServerContext*, const v1::PredictRequest* request,
                       v1::PredictResponse* reply) override {
    std::lock_guard<std::mutex> lock(mu_);
    if (lost_answers_ > 0) {
      --lost_answers_;
      // What gRPC reports when a proxy's connection to a dying replica drops.
      return grpc::Status(grpc::StatusCode::UNKNOWN, "Stream removed");
    }
    const bool exact = static_cast<int>(transitions_.size()) >= exact_after;
    for (int p = 0; p < request->inputs_size() / 3; ++p) {
      const Eigen::VectorXd x =
          Eigen::Vector2d(request->inputs(3 * p), request->inputs(3 * p + 1));
      const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, request->inputs(3 * p + 2));
      const Eigen::VectorXd mean = exact ? plant_->Step(x, u) : x;
      reply->add_mean(mean(0));
      reply->add_mean(mean(1));
      reply->add_variance(1.0);
      reply->add_variance(1.0);
    }
    return grpc::Status::OK;
  }
  grpc::Status PlanInputs(grpc::ServerContext*, const v1::PlanInputsRequest* request,
                          v1::PlanInputsResponse* reply) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(plan_delay_ms_));
    std::lock_guard<std::mutex> lock(mu_);
    ++plan_calls_;
    pending_.push_back(
        {static_cast<int64_t>(transitions_.size()),
         {request->pending_inputs().begin(), request->pending_inputs().end()}});
    reply->set_start_step(request->pending_inputs_size());
    if (distinct_plans_) {  // at n samples, row i: 0.01 n + 0.001 i (inside the bounds)
      reply->set_horizon(config_.horizon());
      reply->set_apply_count(1);
      for (int i = 0; i < config_.horizon(); ++i) {
        reply->add_inputs(0.01 * static_cast<double>(transitions_.size()) + 0.001 * i);
      }
      if (transitions_.size() >= 2) return grpc::Status::OK;
    }
    if (transitions_.size() < 2 || refuse_plans_) {
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, "need 2 samples");
    }
    if (transitions_.size() == 5 && late_plans_at_5 > 0) {
      --late_plans_at_5;
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "refit took too long");
    }
    const int horizon = config_.horizon();
    for (int i = 0; i < horizon; ++i) reply->add_inputs(planned_input);
    reply->set_horizon(horizon);
    reply->set_apply_count(config_.strategy() == v1::STRATEGY_PA ? horizon : 1);
    return grpc::Status::OK;
  }

  // Forgets the data and calls of a run (the options stay).
  void Reset() {
    std::lock_guard<std::mutex> lock(mu_);
    transitions_.clear();
    sequences_.clear();
    batch_sizes_.clear();
    pending_.clear();
    plan_calls_ = 0;
  }

  std::mutex mu_;
  const Plant* plant_;
  v1::SessionConfig config_;
  std::vector<std::string> deleted_;
  std::vector<int> batch_sizes_;
  std::vector<v1::Transition> transitions_;
  std::set<int64_t> sequences_;
  int stall_after_storing = -1;  // AddData that reaches this many samples hangs
  int plan_calls_ = 0;
  int exact_after = 1000000;
  double planned_input = 10.0;  // Outside the bounds: the client clips it.
  bool refuse_plans_ = false;
  int late_plans_at_5 = 0;       // PlanInputs answering DEADLINE_EXCEEDED at 5 samples
  int lost_answers_ = 0;         // Predicts answering UNKNOWN "Stream removed"
  bool distinct_plans_ = false;  // each plan's inputs tell its number and row
  int plan_delay_ms_ = 0;        // each PlanInputs takes at least this long
  // Each PlanInputs: the samples stored then and its pending_inputs.
  std::vector<std::pair<int64_t, std::vector<double>>> pending_;
};

class ExplorationRunTest : public testing::Test {
 protected:
  void SetUp() override {
    config_ = *LoadSimConfig(std::string(EXCITE_SIM_CONFIG_DIR) + "/pendulum.textproto");
    config_.mutable_evaluation()->set_points(50);
    plant_ = *MakePlant(config_.plant());
    service_ = std::make_unique<FakeService>(plant_.get());
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    address_ = "127.0.0.1:" + std::to_string(port);
    client_ = client::ExciteClient::Connect(address_);
  }
  void TearDown() override { server_->Shutdown(); }

  absl::StatusOr<RunSummary> Run(const ExplorationOptions& options = {}) {
    return RunExploration(*client_, *plant_, config_, options);
  }

  v1::SimConfig config_;
  std::unique_ptr<Plant> plant_;
  std::unique_ptr<FakeService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
  std::unique_ptr<client::ExciteClient> client_;
};

TEST_F(ExplorationRunTest, RecAppliesOneClippedInputPerPlan) {
  config_.set_samples(25);
  std::ostringstream log;
  ExplorationOptions options;
  options.log = &log;
  absl::StatusOr<RunSummary> summary = Run(options);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->samples, 25);
  EXPECT_EQ(summary->random_steps, 2);
  EXPECT_EQ(summary->plans, 23);
  EXPECT_EQ(summary->strategy, "rec");
  EXPECT_EQ(summary->session, "sessions/fake");
  ASSERT_EQ(summary->rmse_history.size(), 3u);
  EXPECT_EQ(summary->rmse_history[0].samples, 10);
  EXPECT_EQ(summary->rmse_history[1].samples, 20);
  EXPECT_EQ(summary->rmse_history[2].samples, 25);
  EXPECT_EQ(summary->final_rmse, summary->rmse_history[2].rmse);
  EXPECT_NE(log.str().find("step 8 samples 10 rmse "), std::string::npos) << log.str();

  const std::vector<v1::Transition>& t = service_->transitions_;
  ASSERT_EQ(t.size(), 25u);
  for (size_t k = 0; k < t.size(); ++k) {
    EXPECT_EQ(t[k].sequence(), static_cast<int64_t>(k));
    ASSERT_EQ(t[k].state_size(), 2);
    ASSERT_EQ(t[k].input_size(), 1);
    ASSERT_EQ(t[k].next_state_size(), 2);
    if (k >= 2) {
      EXPECT_EQ(t[k].input(0), 3.0);  // Planned 10, clipped to the bound.
    }
    EXPECT_LE(std::abs(t[k].input(0)), 3.0);
    if (k > 0) {  // The measurement chain: y_{k+1} is the next transition's state.
      EXPECT_EQ(t[k].state(0), t[k - 1].next_state(0));
      EXPECT_EQ(t[k].state(1), t[k - 1].next_state(1));
      EXPECT_NEAR(t[k].timestamp_s() - t[k - 1].timestamp_s(), 0.1, 1e-6);
    }
  }
  // Noise is there: the first measured state is not exactly the initial state.
  EXPECT_NE(t[0].state(0), 0.0);
  ASSERT_EQ(service_->deleted_.size(), 1u);
  EXPECT_EQ(service_->deleted_[0], "sessions/fake");
}

TEST_F(ExplorationRunTest, PaAppliesTheWholePlanAndSplitsBatchesAtEvaluations) {
  config_.mutable_session()->set_strategy(v1::STRATEGY_PA);
  config_.set_samples(40);
  service_->exact_after = 30;
  absl::StatusOr<RunSummary> summary = Run();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->strategy, "pa");
  EXPECT_EQ(summary->random_steps, 2);
  EXPECT_EQ(summary->plans, 3);  // 2 random, then 15 + 15 + 8.
  // Random 1, 1; plan 1 covers 2..16 split at 10; plan 2 17..31 split at 20, 30;
  // plan 3 32..39 up to 40.
  EXPECT_EQ(service_->batch_sizes_, (std::vector<int>{1, 1, 8, 7, 3, 10, 2, 8}));
  ASSERT_EQ(summary->rmse_history.size(), 4u);
  EXPECT_GT(summary->rmse_history[0].rmse, 0.1);
  EXPECT_EQ(summary->rmse_history[0].rmse, summary->rmse_history[1].rmse);
  EXPECT_EQ(summary->rmse_history[2].rmse, 0.0);  // The fake turned exact at 30.
  EXPECT_EQ(summary->final_rmse, 0.0);
  EXPECT_GT(summary->coverage_marginal, 0.0);
  ASSERT_TRUE(summary->coverage_joint.has_value());
  EXPECT_GT(*summary->coverage_joint, 0.0);
}

// A real-time plant: every tick's input is a plan's row or the last one held,
// and the inputs each plan was told are pending are exactly the ones applied.
// Plans take 25 ms at 100 Hz: each misses 2 or more ticks, which are committed.
TEST_F(ExplorationRunTest, RealTimePlantAppliesWhatItCommittedTo) {
  config_.set_samples(60);
  service_->distinct_plans_ = true;
  service_->plan_delay_ms_ = 25;
  ExplorationOptions options;
  options.realtime_hz = 100;
  absl::StatusOr<RunSummary> summary = Run(options);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->samples, 60);
  const RealtimeStats& rt = summary->realtime;
  EXPECT_EQ(rt.hz, 100);
  EXPECT_EQ(rt.ticks_from_plan + rt.ticks_fell_back + summary->random_steps, 60);
  EXPECT_GT(rt.ticks_from_plan, 20);
  EXPECT_GT(summary->plans, 5);
  EXPECT_NE(RunSummaryToJson(*summary).find("\"realtime\": {\"hz\": 100, "),
            std::string::npos);

  const std::vector<v1::Transition>& t = service_->transitions_;
  ASSERT_EQ(t.size(), 60u);
  int planned = 0;
  for (const auto& [stored, pending] : service_->pending_) {
    if (stored < 2) continue;  // FAILED_PRECONDITION: nothing planned
    // The first plan knows no round trip yet; the later ones commit the ticks
    // a 25 ms round trip misses at 100 Hz (ceil(2.5) - 1 = 2 or more).
    if (planned++ > 0) {
      EXPECT_GE(pending.size(), 2u) << "plan at " << stored;
    }
    for (size_t i = 0; i < pending.size() && stored + i < t.size(); ++i) {
      EXPECT_EQ(t[stored + i].input(0), pending[i]) << "sample " << stored + i;
    }
  }
  EXPECT_EQ(planned, summary->plans);
  // The measurement chain holds as in lock-step.
  for (size_t k = 1; k < t.size(); ++k) {
    EXPECT_EQ(t[k].state(0), t[k - 1].next_state(0));
    EXPECT_EQ(t[k].sequence(), static_cast<int64_t>(k));
  }
}

// Plans that are never late (the fake answers in a millisecond, a tick is 100
// ms): the real-time plant applies exactly the lock-step run's inputs, random
// ones until the first plan included, and measures the same states.
TEST_F(ExplorationRunTest, RealTimeWithTimelyPlansAppliesTheLockStepInputs) {
  config_.set_samples(25);
  service_->distinct_plans_ = true;
  absl::StatusOr<RunSummary> lock_step = Run();
  ASSERT_TRUE(lock_step.ok()) << lock_step.status();
  const std::vector<v1::Transition> expected = service_->transitions_;
  service_->Reset();
  ExplorationOptions options;
  options.realtime_hz = 10;
  absl::StatusOr<RunSummary> real_time = Run(options);
  ASSERT_TRUE(real_time.ok()) << real_time.status();
  EXPECT_EQ(real_time->realtime.late_plans, 0);
  EXPECT_EQ(real_time->random_steps, lock_step->random_steps);
  const std::vector<v1::Transition>& t = service_->transitions_;
  ASSERT_EQ(t.size(), expected.size());
  for (size_t k = 0; k < t.size(); ++k) {
    EXPECT_EQ(t[k].input(0), expected[k].input(0)) << k;
    EXPECT_EQ(t[k].next_state(0), expected[k].next_state(0)) << k;
    EXPECT_EQ(t[k].next_state(1), expected[k].next_state(1)) << k;
  }
  EXPECT_EQ(real_time->final_rmse, lock_step->final_rmse);
}

TEST_F(ExplorationRunTest, KeepSession) {
  config_.set_samples(5);
  ExplorationOptions options;
  options.keep_session = true;
  ASSERT_TRUE(Run(options).ok());
  EXPECT_TRUE(service_->deleted_.empty());
}

// DEADLINE_EXCEEDED is retried up to 3 times (the server keeps a stopped refit's
// progress); a 4th is an error naming the call.
TEST_F(ExplorationRunTest, PlanDeadlinesAreRetriedThreeTimes) {
  config_.set_samples(12);
  service_->late_plans_at_5 = 3;
  std::ostringstream log;
  ExplorationOptions options;
  options.log = &log;
  absl::StatusOr<RunSummary> summary = Run(options);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->samples, 12);
  EXPECT_EQ(summary->plan_retries, 3);
  EXPECT_EQ(summary->plans, 10);
  EXPECT_NE(log.str().find("PlanInputs missed its deadline at 5 samples (refit took too "
                           "long); retry 3 of 3"),
            std::string::npos)
      << log.str();

  service_->transitions_.clear();
  service_->sequences_.clear();
  service_->late_plans_at_5 = 4;
  summary = Run();
  ASSERT_FALSE(summary.ok());
  EXPECT_EQ(summary.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_NE(summary.status().message().find("PlanInputs"), std::string::npos)
      << summary.status();
}

// An AddData whose answer never comes is retried after data_deadline with the
// same sequence numbers: the resent batch comes back as duplicates and the run
// goes on, every sample stored once. Without a retry window it is an error.
TEST_F(ExplorationRunTest, StuckAddDataIsRetriedWithTheSameSequenceNumbers) {
  client::ClientOptions options;
  options.data_deadline = std::chrono::milliseconds(300);
  options.retry_unavailable = std::chrono::seconds(20);
  client_ = client::ExciteClient::Connect(address_, options);
  config_.set_samples(8);
  service_->stall_after_storing = 4;
  absl::StatusOr<RunSummary> summary = Run();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->samples, 8);
  ASSERT_EQ(service_->transitions_.size(), 8u);
  for (size_t k = 0; k < 8; ++k) {
    EXPECT_EQ(service_->transitions_[k].sequence(), static_cast<int64_t>(k));
  }
  EXPECT_EQ(service_->batch_sizes_.size(), 9u);  // 8 steps, one resent

  options.retry_unavailable = std::chrono::milliseconds(0);
  client_ = client::ExciteClient::Connect(address_, options);
  service_->transitions_.clear();
  service_->sequences_.clear();
  summary = Run();
  ASSERT_FALSE(summary.ok());
  EXPECT_EQ(summary.status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_NE(summary.status().message().find("AddData"), std::string::npos)
      << summary.status();
}

// A Predict whose connection dropped mid-call (a replica killed behind the
// proxy: UNKNOWN "Stream removed") is resent within the retry window; without
// one, the run fails naming Predict. CI once failed on this very case.
TEST_F(ExplorationRunTest, PredictAfterALostAnswerIsResent) {
  client::ClientOptions options;
  options.retry_unavailable = std::chrono::seconds(20);
  client_ = client::ExciteClient::Connect(address_, options);
  config_.set_samples(8);
  service_->lost_answers_ = 2;
  absl::StatusOr<RunSummary> summary = Run();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->samples, 8);
  EXPECT_EQ(service_->lost_answers_, 0);

  options.retry_unavailable = std::chrono::milliseconds(0);
  client_ = client::ExciteClient::Connect(address_, options);
  service_->transitions_.clear();
  service_->sequences_.clear();
  service_->lost_answers_ = 1;
  summary = Run();
  ASSERT_FALSE(summary.ok());
  EXPECT_EQ(summary.status().code(), absl::StatusCode::kUnknown);
  EXPECT_NE(summary.status().message().find("Predict"), std::string::npos)
      << summary.status();
}

// A model that predicts the plant exactly, with unit variance: no multi-step
// error, every error inside its interval, the density of a zero error. A model
// that predicts no motion: errors at both horizons.
TEST_F(ExplorationRunTest, MultiStepErrorsAndCalibrationAreScored) {
  config_.set_samples(10);
  service_->exact_after = 0;
  absl::StatusOr<RunSummary> summary = Run();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->rollout_rmse_10, 0.0);
  EXPECT_EQ(summary->rollout_rmse_30, 0.0);
  EXPECT_EQ(summary->final_inside_95, 1.0);
  EXPECT_NEAR(summary->final_nlpd, 0.5 * std::log(2 * M_PI), 1e-12);

  service_->transitions_.clear();
  service_->sequences_.clear();
  service_->exact_after = 1000000;
  summary = Run();
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_GT(summary->rollout_rmse_10, 0.1);
  EXPECT_GT(summary->rollout_rmse_30, 0.1);
  EXPECT_GT(summary->final_nlpd, 0.5 * std::log(2 * M_PI));
}

// Half of the samples is scored too: the fake is exact only from 30 of 40
// samples, so the midway errors (at 20) are large and the final ones 0.
TEST_F(ExplorationRunTest, MidwayErrorsAreScoredAtHalfTheSamples) {
  config_.set_samples(40);
  service_->exact_after = 30;
  absl::StatusOr<RunSummary> summary = Run();
  ASSERT_TRUE(summary.ok()) << summary.status();
  ASSERT_EQ(summary->rmse_history.size(), 4u);
  EXPECT_EQ(summary->midway_samples, 20);
  EXPECT_EQ(summary->midway_rmse, summary->rmse_history[1].rmse);
  EXPECT_GT(summary->midway_rmse, 0.1);
  EXPECT_GT(summary->midway_rollout_rmse_10, 0.1);
  EXPECT_GT(summary->midway_rollout_rmse_30, 0.1);
  EXPECT_EQ(summary->rollout_rmse_30, 0.0);
}

TEST_F(ExplorationRunTest, FailedPreconditionAfterMinSamplesIsAnError) {
  config_.set_samples(10);
  service_->refuse_plans_ = true;
  absl::StatusOr<RunSummary> summary = Run();
  EXPECT_EQ(summary.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(summary.status().message().find("PlanInputs"), std::string::npos);
  EXPECT_NE(summary.status().message().find("after 2 samples"), std::string::npos)
      << summary.status();
  EXPECT_EQ(service_->deleted_.size(), 1u);  // Cleaned up on failure too.
}

// The idealised reference design never asks for a plan: each transition starts at
// a state drawn in the region, with an input drawn in the bounds, and its next
// state is one plant step from the drawn state (measured with the configured noise).
TEST_F(ExplorationRunTest, UniformDesignDrawsEveryStateAndInputFromTheBoxes) {
  config_.set_samples(25);
  config_.mutable_session()->mutable_noise()->set_variance(1e-12);
  ExplorationOptions options;
  options.uniform_design = true;
  absl::StatusOr<RunSummary> summary = Run(options);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->strategy, "uniform");
  EXPECT_EQ(service_->plan_calls_, 0);
  EXPECT_EQ(summary->plans, 0);
  EXPECT_EQ(summary->random_steps, 0);
  ASSERT_EQ(service_->transitions_.size(), 25u);
  const v1::SessionConfig& session = config_.session();
  double moved = 0.0;
  for (size_t k = 0; k < service_->transitions_.size(); ++k) {
    const v1::Transition& t = service_->transitions_[k];
    EXPECT_EQ(t.sequence(), static_cast<int64_t>(k));
    const Eigen::Vector2d x(t.state(0), t.state(1));
    for (int i = 0; i < 2; ++i) {
      EXPECT_GE(x(i), session.state_bounds(i).lower() - 1e-5);
      EXPECT_LE(x(i), session.state_bounds(i).upper() + 1e-5);
    }
    EXPECT_GE(t.input(0), session.input_bounds(0).lower());
    EXPECT_LE(t.input(0), session.input_bounds(0).upper());
    const Eigen::VectorXd next =
        plant_->Step(x, Eigen::VectorXd::Constant(1, t.input(0)));
    EXPECT_NEAR(t.next_state(0), next(0), 1e-4);
    EXPECT_NEAR(t.next_state(1), next(1), 1e-4);
    if (k > 0) {
      moved += std::abs(t.state(0) - service_->transitions_[k - 1].next_state(0));
    }
  }
  EXPECT_GT(moved, 1.0);                        // states jump: not a trajectory
  ASSERT_EQ(summary->rmse_history.size(), 3u);  // at 10, 20, 25
  EXPECT_EQ(summary->final_rmse_per_dimension.size(), 2u);
}

TEST_F(ExplorationRunTest, SameSeedSameData) {
  config_.set_samples(6);
  ASSERT_TRUE(Run().ok());
  const std::vector<v1::Transition> first = service_->transitions_;
  service_->transitions_.clear();
  service_->sequences_.clear();
  ASSERT_TRUE(Run().ok());
  ASSERT_EQ(service_->transitions_.size(), first.size());
  for (size_t k = 0; k < first.size(); ++k) {
    EXPECT_EQ(service_->transitions_[k].next_state(0), first[k].next_state(0));
    EXPECT_EQ(service_->transitions_[k].input(0), first[k].input(0));
  }
}

}  // namespace
}  // namespace excite::sim
