#ifndef EXCITE_SERVER_SERVICE_SESSION_PROTO_H_
#define EXCITE_SERVER_SERVICE_SESSION_PROTO_H_

#include <Eigen/Dense>

#include "excite/v1/exploration_service.pb.h"
#include "google/protobuf/repeated_field.h"
#include "server/session/session.h"

namespace excite::service {

using session::PlanResult;
using session::SessionDescription;

// The wire's messages of a session's results (the service's half of the
// translation; Session speaks in engine types).

// name, config, display name, labels, create time and the snapshot.
v1::Session SessionToProto(const SessionDescription& description);

// Inputs, predicted states and variances row-major, horizon, apply_count and the
// solver's summary.
v1::PlanInputsResponse PlanToProto(const PlanResult& result);

// The history's series as the wire has them.
v1::SessionHistory HistoryToProto(const session::LearningHistory& history);

// `matrix` row by row appended to `out`.
void AppendRowMajor(const Eigen::MatrixXd& matrix,
                    google::protobuf::RepeatedField<double>* out);

// `values` (rows x cols, row-major; the caller checked the size) as a matrix.
Eigen::MatrixXd RowMajorToMatrix(const google::protobuf::RepeatedField<double>& values,
                                 Eigen::Index rows, Eigen::Index cols);

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_SESSION_PROTO_H_
