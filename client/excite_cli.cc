// excite: command-line client of excite-server.
//
//   excite [--server=HOST:PORT] sessions list [--filter 'labels.KEY = "VALUE" AND ...']
//   excite sessions get NAME
//   excite sessions create --config FILE [--id ID] [--display_name TEXT]
//                          [--labels KEY=VALUE,...]
//   excite sessions delete NAME
//   excite predict NAME --z 'x1,..,u1,..[,x1,..]' [--include_noise]
//   excite plan NAME --state 'x1,x2,..' [--pending_inputs 'u1,..']
//   excite rollout NAME --state 'x1,x2,..' --inputs 'u1,..' [--include_noise]
//   excite add NAME [FILE]
//   excite export NAME FILE
//   excite export-model NAME FILE
//   excite import FILE [--id ID]
// The session is the first argument after the command everywhere (--session NAME
// is kept for predict and plan; --session_id for import's --id).
//
// add streams transitions from a CSV file (or stdin) into a session, in the layout
// of client/transition_csv.h (the one excite-sim --trajectory writes): one row per
// transition, x (state_dim numbers), u (input_dim), x_next (state_dim) and
// optionally an integer sequence number; without one, rows are numbered after the
// session's last sequence (so they are always added; with one, a row whose number
// is stored is not stored again, and a rerun is safe). Any row that is not such
// numbers is an error naming its line; nothing is sent then. export writes the session
// (config, samples, last hyperparameters) to FILE as a binary SessionArchive; import
// creates a session from such a file (under its exported id unless --id is given).
// --output=json prints each result as one JSON document (protobuf's JSON mapping,
// so 64-bit counts are strings: "sample_count":"40"; export's count too).
//
// NAME is "sessions/{id}" or just the id. Exit status: 0 on success, 1 when the
// server returns an error (printed with its gRPC code name) or cannot be reached,
// or on a local error (a file that cannot be read or written: printed as such),
// 2 on a usage error.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "client/connection_flags.h"
#include "client/excite_client.h"
#include "client/transition_csv.h"
#include "common/usage.h"
#include "google/protobuf/text_format.h"
#include "google/protobuf/util/json_util.h"
#include "google/protobuf/util/time_util.h"
#include "server/service/config_text.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051", "excite-server address HOST:PORT.");
ABSL_FLAG(std::string, config, "", "sessions create: SessionConfig textproto file.");
ABSL_FLAG(std::string, id, "",
          "sessions create: session id (generated if empty); import: id of the new "
          "session (default: the exported session's id).");
ABSL_FLAG(std::string, session, "",
          "predict/plan: session NAME (the same as giving it after the command).");
ABSL_FLAG(std::string, z, "", "predict: comma-separated z = (x, u) points, row-major.");
ABSL_FLAG(bool, include_noise, false,
          "predict/rollout: add the noise variance (measured, not true, states).");
ABSL_FLAG(std::string, state, "", "plan/rollout: comma-separated current state.");
ABSL_FLAG(std::string, pending_inputs, "",
          "plan: comma-separated inputs (row-major, input_dim per step) the plant "
          "applies from --state before the plan starts.");
ABSL_FLAG(std::string, inputs, "",
          "rollout: comma-separated inputs (row-major, input_dim per step) to roll "
          "the model along.");
ABSL_FLAG(int, page_size, 0, "sessions list: page size (0: server default).");
ABSL_FLAG(std::string, filter, "",
          "sessions list: only sessions whose labels match, e.g. "
          "'labels.plant = \"pendulum\" AND labels.run:*'.");
ABSL_FLAG(std::string, display_name, "", "sessions create: what a person calls it.");
ABSL_FLAG(
    std::vector<std::string>, labels, {},
    "sessions create: comma-separated KEY=VALUE labels, e.g. plant=pendulum,lab=b12.");
ABSL_FLAG(std::string, session_id, "", "import: the same as --id (kept for scripts).");
ABSL_FLAG(std::string, header, "auto",
          "add: whether the CSV's first row is a header: yes, no, or auto (it is if "
          "every field is a name, not a number).");
ABSL_FLAG(int, timeout_s, 60, "Deadline of each call in seconds.");
ABSL_FLAG(int, retry_unavailable_s, 0,
          "Resend a call that failed UNAVAILABLE (a server restarting, a replica failing "
          "over behind a proxy) for up to this many seconds, as excite-sim does; 0: "
          "fail at once.");
ABSL_FLAG(int, max_message_mb, 64,
          "Largest message sent or received, in MiB (export/import of big sessions).");
ABSL_FLAG(std::string, output, "text", "text (for people) or json (one JSON document).");

namespace {

constexpr char kUsage[] =
    "excite [--server=HOST:PORT] [--output=text|json] [--timeout_s=S]\n"
    "       [--retry_unavailable_s=S] COMMAND\n"
    "  sessions list [--filter='labels.KEY = \"VALUE\" AND ...'] [--page_size=N]\n"
    "  sessions get NAME\n"
    "  sessions create --config=FILE [--id=ID] [--display_name=TEXT]\n"
    "                  [--labels=KEY=VALUE,...]\n"
    "  sessions delete NAME\n"
    "  predict NAME --z='x1,..,u1,..[,x1,..]' [--include_noise]\n"
    "  plan NAME --state='x1,x2,...' [--pending_inputs='u1,...']\n"
    "  rollout NAME --state='x1,x2,...' --inputs='u1,...' [--include_noise]\n"
    "  history NAME      (plans and the learning curve the server kept)\n"
    "  add NAME [FILE] [--header=auto|yes|no]\n"
    "                    (CSV x0..,u0..,x0_next..[,sequence], as excite-sim\n"
    "                    --trajectory writes it; stdin without FILE)\n"
    "  export NAME FILE\n"
    "  export-model NAME FILE   (the fitted model, to predict without a server)\n"
    "  import FILE [--id=ID]\n"
    "NAME is sessions/{id} or {id}. Connection: --tls_ca, --tls_cert, --tls_key,\n"
    "--auth_token_file; --max_message_mb for big exports. --help lists every flag,\n"
    "--version the version and commit.";

int UsageError(const std::string& message) {
  std::fprintf(stderr, "excite: %s\nusage:\n%s\n", message.c_str(), kUsage);
  return 2;
}

// An error of the server, or of reaching it.
int Fail(const absl::Status& status) {
  const std::string message(status.message());
  if (status.code() == absl::StatusCode::kUnavailable) {
    std::fprintf(stderr,
                 "excite: cannot reach excite-server at %s (is it running, and are "
                 "--server and the TLS flags right?): %s\n",
                 absl::GetFlag(FLAGS_server).c_str(), message.c_str());
  } else if (status.code() == absl::StatusCode::kDeadlineExceeded) {
    std::fprintf(stderr, "excite: no answer within --timeout_s=%d s: %s\n",
                 absl::GetFlag(FLAGS_timeout_s), message.c_str());
  } else {
    std::fprintf(stderr, "excite: %s: %s\n",
                 absl::StatusCodeToString(status.code()).c_str(), message.c_str());
  }
  return 1;
}

// An error here, before or after talking to the server (a file, an argument).
int LocalFail(const absl::Status& status) {
  std::fprintf(stderr, "excite: %s\n", std::string(status.message()).c_str());
  return 1;
}

bool Json() { return absl::GetFlag(FLAGS_output) == "json"; }

// `message` as one line of JSON (protobuf's mapping, field names as in the proto).
void PrintJson(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  if (!google::protobuf::util::MessageToJsonString(message, &json, options).ok()) {
    json = "{}";
  }
  std::printf("%s\n", json.c_str());
}

std::string FullName(const std::string& name) {
  return absl::StartsWith(name, "sessions/") ? name : absl::StrCat("sessions/", name);
}

bool ParseNumbers(const std::string& text, std::vector<double>* values) {
  values->clear();
  for (absl::string_view part : absl::StrSplit(text, ',', absl::SkipWhitespace())) {
    double v = 0.0;
    if (!absl::SimpleAtod(absl::StripAsciiWhitespace(part), &v)) return false;
    values->push_back(v);
  }
  return !values->empty();
}

std::string Row(const google::protobuf::RepeatedField<double>& values, int row,
                int cols) {
  std::vector<std::string> parts;
  for (int j = 0; j < cols; ++j) {
    const int index = row * cols + j;
    if (index < values.size()) parts.push_back(absl::StrFormat("%10.4g", values[index]));
  }
  return absl::StrJoin(parts, " ");
}

std::string StrategyName(excite::v1::Strategy strategy) {
  return excite::v1::Strategy_Name(strategy);
}

int ListSessions(excite::client::ExciteClient& client) {
  std::string token;
  int count = 0;
  excite::v1::ListSessionsResponse all;  // every page, for --output=json
  do {
    absl::StatusOr<excite::v1::ListSessionsResponse> page = client.ListSessions(
        absl::GetFlag(FLAGS_page_size), token, absl::GetFlag(FLAGS_filter));
    if (!page.ok()) return Fail(page.status());
    token = page->next_page_token();
    if (Json()) {
      for (const excite::v1::Session& s : page->sessions()) *all.add_sessions() = s;
      continue;
    }
    for (const excite::v1::Session& s : page->sessions()) {
      // Labels in key order (a protobuf map has none).
      const std::map<std::string, std::string> labels(s.labels().begin(),
                                                      s.labels().end());
      std::printf(
          "%-28s %-24s created=%s strategy=%s state_dim=%d input_dim=%d samples=%lld "
          "labels=%s\n",
          s.name().c_str(), absl::StrCat("\"", s.display_name(), "\"").c_str(),
          s.has_create_time()
              ? google::protobuf::util::TimeUtil::ToString(s.create_time()).c_str()
              : "unknown",
          StrategyName(s.config().strategy()).c_str(), s.config().state_dim(),
          s.config().input_dim(), static_cast<long long>(s.sample_count()),
          absl::StrJoin(labels, ",", absl::PairFormatter("=")).c_str());
      ++count;
    }
  } while (!token.empty());
  if (Json()) {
    PrintJson(all);
  } else if (count == 0) {
    std::printf("no sessions\n");
  }
  return 0;
}

int PrintSession(const excite::v1::Session& session) {
  if (Json()) {
    PrintJson(session);
    return 0;
  }
  std::string text;
  google::protobuf::TextFormat::PrintToString(session, &text);
  std::printf("%s", text.c_str());
  return 0;
}

int Sessions(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  if (args.size() < 2) return UsageError("sessions: missing sub-command");
  const std::string& verb = args[1];
  if (verb == "list") {
    if (args.size() != 2) return UsageError("sessions list takes no argument");
    return ListSessions(client);
  }
  if (verb == "get" || verb == "delete") {
    if (args.size() != 3) return UsageError(absl::StrCat("sessions ", verb, " NAME"));
    const std::string name = FullName(args[2]);
    if (verb == "get") {
      absl::StatusOr<excite::v1::Session> session = client.GetSession(name);
      if (!session.ok()) return Fail(session.status());
      return PrintSession(*session);
    }
    if (absl::Status s = client.DeleteSession(name); !s.ok()) return Fail(s);
    if (Json()) {
      std::printf("{\"deleted\":\"%s\"}\n", name.c_str());
    } else {
      std::printf("deleted %s\n", name.c_str());
    }
    return 0;
  }
  if (verb == "create") {
    if (args.size() != 2) {
      return UsageError(
          "sessions create --config FILE [--id ID] [--display_name TEXT] [--labels "
          "K=V,...]");
    }
    if (absl::GetFlag(FLAGS_config).empty())
      return UsageError("sessions create: --config");
    absl::StatusOr<excite::v1::SessionConfig> config =
        excite::service::LoadSessionConfigFile(absl::GetFlag(FLAGS_config));
    if (!config.ok()) return LocalFail(config.status());
    excite::v1::CreateSessionRequest request;
    request.set_session_id(absl::GetFlag(FLAGS_id));
    *request.mutable_config() = *std::move(config);
    request.set_display_name(absl::GetFlag(FLAGS_display_name));
    for (const std::string& label : absl::GetFlag(FLAGS_labels)) {
      const std::vector<std::string> key_value =
          absl::StrSplit(label, absl::MaxSplits('=', 1));
      if (key_value.size() != 2) {
        return UsageError(absl::StrCat("--labels: \"", label, "\" is not KEY=VALUE"));
      }
      (*request.mutable_labels())[key_value[0]] = key_value[1];
    }
    absl::StatusOr<excite::v1::Session> session = client.CreateSession(request);
    if (!session.ok()) return Fail(session.status());
    if (!Json()) std::printf("created %s\n", session->name().c_str());
    return PrintSession(*session);
  }
  return UsageError(absl::StrCat("sessions: unknown sub-command \"", verb, "\""));
}

// "theta [rad], theta_dot [rad/s]" from a config's names and units, or "x0, x1"
// (`prefix` and the index) when it names none.
std::string DimensionNames(const google::protobuf::RepeatedPtrField<std::string>& names,
                           const google::protobuf::RepeatedPtrField<std::string>& units,
                           int dim, const char* prefix) {
  std::string out;
  for (int i = 0; i < dim; ++i) {
    absl::StrAppend(&out, i == 0 ? "" : ", ",
                    i < names.size() ? names.Get(i) : absl::StrCat(prefix, i));
    if (i < units.size() && !units.Get(i).empty()) {
      absl::StrAppend(&out, " [", units.Get(i), "]");
    }
  }
  return out;
}

// The session NAME of predict and plan: the argument after the command, or
// --session (the older spelling); empty after a usage error was printed.
std::string SessionArgument(const std::vector<std::string>& args, int* exit_code) {
  const std::string& command = args[0];
  const std::string flag = absl::GetFlag(FLAGS_session);
  if (args.size() > 2) {
    *exit_code = UsageError(absl::StrCat(command, " takes one session NAME, got ",
                                         args.size() - 1, " arguments"));
    return "";
  }
  const std::string positional = args.size() == 2 ? args[1] : "";
  if (!positional.empty() && !flag.empty() && FullName(positional) != FullName(flag)) {
    *exit_code = UsageError(absl::StrCat(command, ": the session is given twice (\"",
                                         positional, "\" and --session=", flag, ")"));
    return "";
  }
  if (positional.empty() && flag.empty()) {
    *exit_code = UsageError(absl::StrCat(command, ": which session? ", command, " NAME"));
    return "";
  }
  return FullName(positional.empty() ? flag : positional);
}

int Predict(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  int exit_code = 0;
  const std::string name = SessionArgument(args, &exit_code);
  if (name.empty()) return exit_code;
  excite::v1::PredictRequest request;
  request.set_session(name);
  std::vector<double> z;
  if (!ParseNumbers(absl::GetFlag(FLAGS_z), &z)) {
    return UsageError("predict: --z must be comma-separated numbers");
  }
  for (double v : z) request.add_inputs(v);
  request.set_include_noise(absl::GetFlag(FLAGS_include_noise));
  absl::StatusOr<excite::v1::PredictResponse> response = client.Predict(request);
  if (!response.ok()) return Fail(response.status());
  if (Json()) {
    PrintJson(*response);
    return 0;
  }
  absl::StatusOr<excite::v1::Session> session = client.GetSession(request.session());
  const int dx = session.ok() ? session->config().state_dim() : response->mean_size();
  const int points = dx > 0 ? response->mean_size() / dx : 0;
  std::printf("model_version %lld\n", static_cast<long long>(response->model_version()));
  if (session.ok()) {
    std::printf("next state: %s\n",
                DimensionNames(session->config().state_names(),
                               session->config().state_units(), dx, "x")
                    .c_str());
  }
  for (int i = 0; i < points; ++i) {
    std::printf("point %d\n  mean     %s\n  variance %s\n", i,
                Row(response->mean(), i, dx).c_str(),
                Row(response->variance(), i, dx).c_str());
  }
  return 0;
}

int Plan(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  int exit_code = 0;
  const std::string name = SessionArgument(args, &exit_code);
  if (name.empty()) return exit_code;
  std::vector<double> state, pending;
  if (!ParseNumbers(absl::GetFlag(FLAGS_state), &state)) {
    return UsageError("plan: --state must be comma-separated numbers");
  }
  if (!absl::GetFlag(FLAGS_pending_inputs).empty() &&
      !ParseNumbers(absl::GetFlag(FLAGS_pending_inputs), &pending)) {
    return UsageError("plan: --pending_inputs must be comma-separated numbers");
  }
  absl::StatusOr<excite::v1::PlanInputsResponse> plan =
      client.PlanInputs(name, state, pending);
  if (!plan.ok()) return Fail(plan.status());
  if (Json()) {
    PrintJson(*plan);
    return 0;
  }
  const int horizon = plan->horizon();
  const int du = horizon > 0 ? plan->inputs_size() / horizon : 0;
  const int dx = horizon > 0 ? plan->predicted_states_size() / horizon : 0;
  std::printf("horizon %d, apply the first %d input(s)", horizon, plan->apply_count());
  if (plan->start_step() > 0) {
    std::printf(" after the %d pending one(s)", plan->start_step());
  }
  std::printf("\n");
  std::printf(
      "solver %s, %d iterations, %.1f ms, objective %.6g nats, model_version %lld\n",
      excite::v1::SolverStatus_Name(plan->solver_status()).c_str(), plan->iterations(),
      plan->wall_time_ms(), plan->objective(),
      static_cast<long long>(plan->model_version()));
  if (absl::StatusOr<excite::v1::Session> session = client.GetSession(name);
      session.ok()) {
    const excite::v1::SessionConfig& c = session->config();
    std::printf("input: %s\nstate: %s\n",
                DimensionNames(c.input_names(), c.input_units(), du, "u").c_str(),
                DimensionNames(c.state_names(), c.state_units(), dx, "x").c_str());
  }
  std::printf("%4s | %-*s | %-*s | %s\n", "step", 11 * du - 1, "input", 11 * dx - 1,
              "predicted state", "latent variance");
  for (int i = 0; i < horizon; ++i) {  // steps counted from --state
    std::printf("%4d | %s | %s | %s\n", plan->start_step() + i,
                Row(plan->inputs(), i, du).c_str(),
                Row(plan->predicted_states(), i, dx).c_str(),
                Row(plan->predicted_variances(), i, dx).c_str());
  }
  return 0;
}

int Rollout(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  int exit_code = 0;
  const std::string name = SessionArgument(args, &exit_code);
  if (name.empty()) return exit_code;
  std::vector<double> state, inputs;
  if (!ParseNumbers(absl::GetFlag(FLAGS_state), &state) ||
      !ParseNumbers(absl::GetFlag(FLAGS_inputs), &inputs)) {
    return UsageError("rollout: --state and --inputs must be comma-separated numbers");
  }
  excite::v1::RolloutRequest request;
  request.set_session(name);
  request.mutable_state()->Add(state.begin(), state.end());
  request.mutable_inputs()->Add(inputs.begin(), inputs.end());
  request.set_include_noise(absl::GetFlag(FLAGS_include_noise));
  absl::StatusOr<excite::v1::RolloutResponse> rolled = client.Rollout(request);
  if (!rolled.ok()) return Fail(rolled.status());
  if (Json()) {
    PrintJson(*rolled);
    return 0;
  }
  const int dx = static_cast<int>(state.size());
  const int steps = dx > 0 ? rolled->means_size() / dx : 0;
  std::string names;
  if (absl::StatusOr<excite::v1::Session> session = client.GetSession(name);
      session.ok()) {
    const excite::v1::SessionConfig& c = session->config();
    names = DimensionNames(c.state_names(), c.state_units(), dx, "x");
  }
  std::printf("model_version %lld; state: %s\n",
              static_cast<long long>(rolled->model_version()), names.c_str());
  std::printf("%4s | %-*s | %s\n", "step", 11 * dx - 1, "mean", "standard deviation");
  for (int k = 0; k < steps; ++k) {
    std::string sd;
    for (int d = 0; d < dx; ++d) {
      absl::StrAppendFormat(&sd, "%s%10.4g", d > 0 ? " " : "",
                            std::sqrt(std::max(0.0, rolled->variances(k * dx + d))));
    }
    std::printf("%4d | %s | %s\n", k, Row(rolled->means(), k, dx).c_str(), sd.c_str());
  }
  return 0;
}

int ExportModel(excite::client::ExciteClient& client,
                const std::vector<std::string>& args) {
  if (args.size() != 3) return UsageError("export-model NAME FILE");
  const std::string name = FullName(args[1]);
  absl::StatusOr<excite::v1::ExportModelResponse> exported = client.ExportModel(name);
  if (!exported.ok()) return Fail(exported.status());
  std::ofstream file(args[2], std::ios::binary | std::ios::trunc);
  file << exported->model_file();
  file.close();
  if (!file) {
    std::fprintf(stderr, "excite: cannot write %s\n", args[2].c_str());
    return 1;
  }
  if (Json()) {
    excite::v1::ExportModelResponse summary = *exported;
    summary.clear_model_file();
    PrintJson(summary);
    return 0;
  }
  std::printf(
      "wrote %s: model file format %u, model_version %lld, %lld samples, %zu bytes\n",
      args[2].c_str(), exported->format_version(),
      static_cast<long long>(exported->model_version()),
      static_cast<long long>(exported->sample_count()), exported->model_file().size());
  return 0;
}

int Export(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  if (args.size() != 3) return UsageError("export NAME FILE");
  const std::string name = FullName(args[1]);
  absl::StatusOr<excite::v1::SessionArchive> archive = client.ExportSession(name);
  if (!archive.ok()) return Fail(archive.status());
  if (absl::Status s = excite::client::WriteSessionArchiveFile(args[2], *archive);
      !s.ok()) {
    return LocalFail(s);
  }
  if (Json()) {
    // Counts as strings, as protobuf's JSON mapping writes the int64 counts of
    // every other command ("stored", "sample_count"): one type per kind of field.
    std::printf("{\"exported\":\"%s\",\"samples\":\"%d\",\"file\":\"%s\"}\n",
                name.c_str(), archive->samples_size(), absl::CEscape(args[2]).c_str());
    return 0;
  }
  std::printf("exported %s (%d samples, %d hyperparameter sets) to %s\n", name.c_str(),
              archive->samples_size(), archive->hyperparameters_size(), args[2].c_str());
  return 0;
}

int Import(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  if (args.size() != 2) return UsageError("import FILE [--id=ID]");
  const std::string id = absl::GetFlag(FLAGS_id);
  const std::string old_id = absl::GetFlag(FLAGS_session_id);
  if (!id.empty() && !old_id.empty() && id != old_id) {
    return UsageError("import: --id and --session_id (the same flag) differ");
  }
  absl::StatusOr<excite::v1::SessionArchive> archive =
      excite::client::ReadSessionArchiveFile(args[1]);
  if (!archive.ok()) return LocalFail(archive.status());
  absl::StatusOr<excite::v1::Session> session =
      client.ImportSession(*archive, id.empty() ? old_id : id);
  if (!session.ok()) return Fail(session.status());
  if (Json()) return PrintSession(*session);
  std::printf("imported %s (%lld samples) from %s\n", session->name().c_str(),
              static_cast<long long>(session->sample_count()), args[1].c_str());
  return 0;
}

int Add(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  if (args.size() != 2 && args.size() != 3) return UsageError("add NAME [FILE]");
  const std::string name = FullName(args[1]);
  std::string text;
  if (args.size() == 3 && args[2] != "-") {
    std::ifstream in(args[2]);
    if (!in) return LocalFail(absl::NotFoundError(absl::StrCat("cannot read ", args[2])));
    std::stringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
  } else {
    std::stringstream buffer;
    buffer << std::cin.rdbuf();
    text = buffer.str();
  }
  absl::StatusOr<excite::v1::Session> session = client.GetSession(name);
  if (!session.ok()) return Fail(session.status());
  absl::StatusOr<excite::client::CsvHeader> header =
      excite::client::ParseCsvHeaderMode(absl::GetFlag(FLAGS_header));
  if (!header.ok()) return UsageError(std::string(header.status().message()));
  absl::StatusOr<std::vector<excite::v1::Transition>> transitions =
      excite::client::ParseTransitionCsv(text, session->config().state_dim(),
                                         session->config().input_dim(),
                                         session->last_sequence() + 1, *header);
  if (!transitions.ok()) {
    return LocalFail(absl::InvalidArgumentError(absl::StrCat(
        args.size() == 3 ? args[2] : "stdin", ": ", transitions.status().message())));
  }
  // One acknowledged message per 256 rows: on an error, what was acknowledged is
  // stored. (Rerunning a file stores each row once only if it numbers its rows.)
  constexpr size_t kRowsPerMessage = 256;
  std::unique_ptr<excite::client::DataStream> stream = client.OpenDataStream(name);
  excite::v1::AddDataResponse total;
  for (size_t first = 0; first < transitions->size(); first += kRowsPerMessage) {
    const size_t end = std::min(first + kRowsPerMessage, transitions->size());
    absl::StatusOr<excite::v1::AddDataAck> ack =
        stream->Send({transitions->begin() + static_cast<std::ptrdiff_t>(first),
                      transitions->begin() + static_cast<std::ptrdiff_t>(end)});
    if (!ack.ok()) {
      if (first > 0) {
        std::fprintf(stderr, "excite: rows 1-%zu were stored (%lld new)\n", first,
                     static_cast<long long>(total.stored()));
      }
      return Fail(ack.status());
    }
    total.set_stored(total.stored() + ack->stored());
    total.set_duplicates(total.duplicates() + ack->duplicates());
    total.set_sample_count(ack->sample_count());
    total.set_model_version(ack->model_version());
  }
  if (absl::Status s = stream->Close(); !s.ok()) return Fail(s);
  if (transitions->empty()) total.set_sample_count(session->sample_count());
  if (Json()) {
    PrintJson(total);
  } else {
    std::printf("added %zu rows to %s: %lld stored, %lld already there; %lld samples\n",
                transitions->size(), name.c_str(), static_cast<long long>(total.stored()),
                static_cast<long long>(total.duplicates()),
                static_cast<long long>(total.sample_count()));
  }
  return 0;
}

}  // namespace

namespace {

// Edit distance (insertions, deletions, substitutions), for "did you mean".
size_t EditDistance(absl::string_view a, absl::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1])});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// The last record of each series and the counts: what a person checks first.
int History(excite::client::ExciteClient& client, const std::vector<std::string>& args) {
  int exit_code = 0;
  const std::string name = SessionArgument(args, &exit_code);
  if (name.empty()) return exit_code;
  absl::StatusOr<excite::v1::SessionHistory> history = client.GetSessionHistory(name);
  if (!history.ok()) return Fail(history.status());
  if (Json()) {
    PrintJson(*history);
    return 0;
  }
  absl::StatusOr<excite::v1::Session> session = client.GetSession(name);
  const int dx = session.ok() ? session->config().state_dim() : 0;
  if (session.ok()) {
    std::printf("per state dimension: %s\n",
                DimensionNames(session->config().state_names(),
                               session->config().state_units(), dx, "x")
                    .c_str());
  }
  std::printf("%d plans", history->plans_size());
  if (!history->plans().empty()) {
    const excite::v1::PlanRecord& last = *history->plans().rbegin();
    int limited = 0;
    for (const excite::v1::PlanRecord& p : history->plans()) {
      limited += p.solver_status() == excite::v1::SOLVER_STATUS_TIME_LIMIT;
    }
    std::printf(
        "; the last at %lld samples, objective %.6g, %.1f ms; %d hit the time limit",
        static_cast<long long>(last.sample_count()), last.objective(),
        last.wall_time_ms(), limited);
  }
  std::printf("\n");
  std::printf("%4s | %-*s | %s\n", "n", 11 * dx - 1, "one-step RMSE of the next batch",
              "mean std over the region");
  // Rows at the samples of the uncertainty records, with the batch error nearest
  // before each (the two series are recorded at different times).
  const auto& errors = history->batch_errors();
  int e = 0;
  for (const excite::v1::UncertaintyRecord& u : history->uncertainty()) {
    while (e + 1 < errors.size() && errors[e + 1].sample_count() <= u.sample_count()) ++e;
    const bool has_error =
        !errors.empty() && errors[e].sample_count() <= u.sample_count();
    std::printf("%4lld | %-*s | %s\n", static_cast<long long>(u.sample_count()),
                11 * dx - 1, has_error ? Row(errors[e].rmse(), 0, dx).c_str() : "-",
                Row(u.mean_std(), 0, dx).c_str());
  }
  if (history->uncertainty().empty()) {
    for (const excite::v1::BatchError& error : errors) {
      std::printf("%4lld | %s | -\n", static_cast<long long>(error.sample_count()),
                  Row(error.rmse(), 0, dx).c_str());
    }
  }
  return 0;
}

std::string UnknownCommand(const std::string& command) {
  std::string message = absl::StrCat("unknown command \"", command, "\"");
  const std::string lower = absl::AsciiStrToLower(command);
  std::string best;
  size_t best_distance = 3;  // suggest only within 2 edits
  for (const char* known : {"sessions", "predict", "plan", "rollout", "history", "add",
                            "export", "export-model", "import"}) {
    const size_t d = EditDistance(lower, known);
    if (d < best_distance || absl::StartsWith(known, lower)) {
      best_distance = std::min(d, best_distance);
      best = known;
    }
  }
  if (!best.empty()) absl::StrAppend(&message, " (did you mean ", best, "?)");
  return message;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> positional = excite::ParseFlags(argc, argv, kUsage);
  std::vector<std::string> args(positional.begin() + 1, positional.end());
  if (args.empty()) return UsageError("missing command");

  excite::client::ClientOptions options;
  const int timeout_s = absl::GetFlag(FLAGS_timeout_s);
  if (timeout_s < 1) return UsageError("--timeout_s must be >= 1");
  options.default_deadline = std::chrono::seconds(timeout_s);
  options.plan_deadline = std::chrono::seconds(timeout_s);
  options.retry_unavailable =
      std::chrono::seconds(std::max(0, absl::GetFlag(FLAGS_retry_unavailable_s)));
  options.max_message_mb = absl::GetFlag(FLAGS_max_message_mb);
  if (options.max_message_mb < 1 || options.max_message_mb > 2047) {
    return UsageError("--max_message_mb must be in [1, 2047]");
  }
  if (const std::string output = absl::GetFlag(FLAGS_output);
      output != "text" && output != "json") {
    return UsageError(
        absl::StrCat("--output must be text or json, not \"", output, "\""));
  }
  if (absl::Status s = excite::client::ApplyConnectionFlags(&options); !s.ok()) {
    return UsageError(std::string(s.message()));
  }
  std::unique_ptr<excite::client::ExciteClient> client =
      excite::client::ExciteClient::Connect(absl::GetFlag(FLAGS_server), options);

  const std::string& command = args[0];
  if (command == "sessions") return Sessions(*client, args);
  if (command == "export") return Export(*client, args);
  if (command == "import") return Import(*client, args);
  if (command == "add") return Add(*client, args);
  if (command == "predict") return Predict(*client, args);
  if (command == "plan") return Plan(*client, args);
  if (command == "rollout") return Rollout(*client, args);
  if (command == "export-model") return ExportModel(*client, args);
  if (command == "history") return History(*client, args);
  return UsageError(UnknownCommand(command));
}
