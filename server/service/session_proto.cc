#include "server/service/session_proto.h"

#include "google/protobuf/util/time_util.h"
#include "server/service/resource_name.h"
#include "server/service/session_options.h"
#include "server/service/store_conversion.h"
#include "server/service/strategy_names.h"

namespace excite::service {
namespace {

using RowMajorMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

v1::SolverStatus ToProto(plan::PlanStatus status) {
  switch (status) {
    case plan::PlanStatus::kConverged:
      return v1::SOLVER_STATUS_CONVERGED;
    case plan::PlanStatus::kTimeLimit:
      return v1::SOLVER_STATUS_TIME_LIMIT;
    case plan::PlanStatus::kIterationLimit:
      return v1::SOLVER_STATUS_ITERATION_LIMIT;
    case plan::PlanStatus::kNotConverged:
      return v1::SOLVER_STATUS_NOT_CONVERGED;
  }
  return v1::SOLVER_STATUS_UNSPECIFIED;
}

}  // namespace

void AppendRowMajor(const Eigen::MatrixXd& matrix,
                    google::protobuf::RepeatedField<double>* out) {
  out->Reserve(out->size() + static_cast<int>(matrix.size()));
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    for (Eigen::Index j = 0; j < matrix.cols(); ++j) out->Add(matrix(i, j));
  }
}

Eigen::MatrixXd RowMajorToMatrix(const google::protobuf::RepeatedField<double>& values,
                                 Eigen::Index rows, Eigen::Index cols) {
  return Eigen::Map<const RowMajorMatrix>(values.data(), rows, cols);
}

v1::PlanInputsResponse PlanToProto(const PlanResult& result) {
  v1::PlanInputsResponse response;
  AppendRowMajor(result.plan.inputs, response.mutable_inputs());
  AppendRowMajor(result.plan.states, response.mutable_predicted_states());
  AppendRowMajor(result.plan.variances, response.mutable_predicted_variances());
  response.set_horizon(static_cast<int32_t>(result.plan.inputs.rows()));
  response.set_apply_count(result.plan.apply_count);
  response.set_objective(result.summary.objective);
  response.set_solver_status(ToProto(result.summary.status));
  response.set_iterations(result.summary.iterations);
  response.set_wall_time_ms(result.summary.wall_time_ms);
  response.set_safe_box_violation(result.summary.safe_box_violation);
  response.set_planned_by(WireStrategy(result.summary.planned_by));
  response.set_model_version(result.model_version);
  response.set_start_step(result.start_step);
  return response;
}

v1::SessionHistory HistoryToProto(const session::LearningHistory& history) {
  v1::SessionHistory proto;
  for (const session::PlanRecord& plan : history.plans()) {
    v1::PlanRecord* out = proto.add_plans();
    out->set_sample_count(plan.sample_count);
    out->set_model_version(plan.model_version);
    *out->mutable_time() =
        google::protobuf::util::TimeUtil::MillisecondsToTimestamp(plan.unix_ms);
    out->set_planned_by(WireStrategy(plan.planned_by));
    out->set_solver_status(ToProto(plan.status));
    out->set_objective(plan.objective);
    out->set_wall_time_ms(plan.wall_time_ms);
    out->set_iterations(plan.iterations);
  }
  for (const session::BatchError& batch : history.batch_errors()) {
    v1::BatchError* out = proto.add_batch_errors();
    out->set_sample_count(batch.sample_count);
    out->set_model_version(batch.model_version);
    out->set_batch_size(batch.batch_size);
    out->mutable_rmse()->Add(batch.rmse.data(), batch.rmse.data() + batch.rmse.size());
  }
  for (const session::UncertaintyRecord& record : history.uncertainty()) {
    v1::UncertaintyRecord* out = proto.add_uncertainty();
    out->set_sample_count(record.sample_count);
    out->set_model_version(record.model_version);
    out->mutable_mean_std()->Add(record.mean_std.data(),
                                 record.mean_std.data() + record.mean_std.size());
  }
  return proto;
}

v1::Session SessionToProto(const SessionDescription& description) {
  v1::Session proto;
  proto.set_name(SessionName(description.id));
  // A damaged session's bytes may not parse: it is described without a config.
  if (!proto.mutable_config()->ParseFromString(description.config)) proto.clear_config();
  proto.set_display_name(description.display_name);
  proto.mutable_labels()->insert(description.labels.begin(), description.labels.end());
  if (const int64_t created = WireUnixMs(description.created_unix_ms); created > 0) {
    *proto.mutable_create_time() =
        google::protobuf::util::TimeUtil::MillisecondsToTimestamp(created);
  }
  const session::SessionSnapshot& snapshot = description.snapshot;
  proto.set_sample_count(snapshot.sample_count);
  proto.set_last_sequence(snapshot.last_sequence);
  proto.set_model_version(snapshot.model_version);
  for (const session::OutputSnapshot& output : snapshot.outputs) {
    v1::OutputModel* out = proto.add_outputs();
    *out->mutable_hyperparameters() = ToProto(output.hyperparameters);
    if (output.log_marginal_likelihood.has_value()) {
      out->set_log_marginal_likelihood(*output.log_marginal_likelihood);
    }
    out->set_prior_mean(output.prior_mean);
    out->mutable_prior_mean_slopes()->Add(output.prior_mean_slopes.begin(),
                                          output.prior_mean_slopes.end());
    out->set_inducing_points(output.inducing_points);
    out->mutable_lengthscales_at_bound()->Add(output.lengthscales_at_bound.begin(),
                                              output.lengthscales_at_bound.end());
    out->set_signal_variance_at_bound(output.signal_variance_at_bound);
  }
  if (snapshot.last_plan.has_value()) {
    *proto.mutable_last_plan() = PlanToProto(*snapshot.last_plan);
  }
  return proto;
}

}  // namespace excite::service
