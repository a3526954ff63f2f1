// End to end: the real excite-server and the real excite-sim as separate processes
// over loopback, a short pendulum exploration with rec and with pa.

#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "tests/e2e/subprocess.h"

namespace excite::testing {
namespace {

using std::chrono::seconds;

constexpr char kListeningPrefix[] = "excite-server listening on ";

// A fresh directory under the test's temp dir, removed at destruction.
class TempDir {
 public:
  explicit TempDir(const std::string& name) {
    std::string pattern = ::testing::TempDir() + "/" + name + "-XXXXXX";
    path_ = mkdtemp(pattern.data()) != nullptr ? pattern : "";
  }
  ~TempDir() {
    std::error_code ignored;
    if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Where the value of "key" starts in a JSON text (after the colon and spaces), or
// npos. (No std::regex: GCC 12 warns inside it under ASan, and the asan preset
// builds with -Werror.)
size_t ValueStart(const std::string& json, const std::string& key) {
  size_t at = json.find("\"" + key + "\":");
  if (at == std::string::npos) return at;
  at += key.size() + 3;
  while (at < json.size() && json[at] == ' ') ++at;
  return at;
}

// The number starting at json[at], if there is one; `end` (if given) gets the
// position after it.
std::optional<double> NumberAt(const std::string& json, size_t at,
                               size_t* end = nullptr) {
  if (at >= json.size()) return std::nullopt;
  const char* begin = json.c_str() + at;
  char* stop = nullptr;
  const double value = std::strtod(begin, &stop);
  if (stop == begin) return std::nullopt;
  if (end != nullptr) *end = at + static_cast<size_t>(stop - begin);
  return value;
}

// The number after "key": in a JSON text, if it is one.
std::optional<double> JsonNumber(const std::string& json, const std::string& key) {
  return NumberAt(json, ValueStart(json, key));
}

std::optional<std::string> JsonString(const std::string& json, const std::string& key) {
  const size_t at = ValueStart(json, key);
  if (at >= json.size() || json[at] != '"') return std::nullopt;
  const size_t close = json.find('"', at + 1);
  if (close == std::string::npos) return std::nullopt;
  return json.substr(at + 1, close - at - 1);
}

// rmse_history as (samples, rmse) pairs; a null rmse makes the list shorter.
std::vector<std::pair<double, double>> RmseHistory(const std::string& json) {
  std::vector<std::pair<double, double>> history;
  size_t at = ValueStart(json, "rmse_history");
  if (at >= json.size() || json[at] != '[') return history;
  const size_t end = json.find("]]", at);
  if (end == std::string::npos) return history;
  // Each pair is "[samples, rmse]".
  while ((at = json.find('[', at + 1)) != std::string::npos && at < end) {
    size_t after = 0;
    const std::optional<double> samples = NumberAt(json, at + 1, &after);
    if (!samples.has_value() || json.compare(after, 2, ", ") != 0) continue;
    const std::optional<double> rmse = NumberAt(json, after + 2);
    if (rmse.has_value()) history.emplace_back(*samples, *rmse);
  }
  return history;
}

class EndToEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(work_.path().empty());
    ASSERT_TRUE(std::filesystem::create_directory(data_dir_));
    auto server = Subprocess::Start(
        {EXCITE_SERVER_PATH, "--listen=127.0.0.1:0", "--data_dir=" + data_dir_},
        work_.path() + "/server.out", work_.path() + "/server.err");
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    absl::StatusOr<std::string> line =
        server_->WaitForStdoutLine(kListeningPrefix, seconds(30));
    ASSERT_TRUE(line.ok()) << line.status() << "\nserver stderr:\n"
                           << ReadFileOrEmpty(server_->stderr_path());
    address_ = line->substr(std::string(kListeningPrefix).size());
    ASSERT_FALSE(address_.empty());
  }

  // SIGTERM; the server must drain and exit 0.
  void StopServer() {
    server_->Signal(SIGTERM);
    absl::StatusOr<int> code = server_->Wait(seconds(30));
    ASSERT_TRUE(code.ok()) << code.status();
    EXPECT_EQ(*code, 0) << "server stderr:\n" << ReadFileOrEmpty(server_->stderr_path());
  }

  // Runs excite-sim to completion; returns its exit code.
  int RunSim(const std::vector<std::string>& extra_flags, const std::string& name,
             seconds timeout) {
    std::vector<std::string> argv = {EXCITE_SIM_PATH, "--server=" + address_,
                                     "--config=" EXCITE_PENDULUM_CONFIG};
    argv.insert(argv.end(), extra_flags.begin(), extra_flags.end());
    sim_out_ = work_.path() + "/" + name + ".out";
    sim_err_ = work_.path() + "/" + name + ".err";
    auto sim = Subprocess::Start(argv, sim_out_, sim_err_);
    EXPECT_TRUE(sim.ok()) << sim.status();
    if (!sim.ok()) return -1;
    absl::StatusOr<int> code = (*sim)->Wait(timeout);
    EXPECT_TRUE(code.ok()) << code.status() << "\nexcite-sim stdout:\n"
                           << ReadFileOrEmpty(sim_out_);
    return code.ok() ? *code : -1;
  }

  // A short pendulum run with `strategy` (100 samples, about 2-15 s on 2 cores; seed 1
  // explores well with both rec and pa); checks the summary.
  void ExploreAndCheck(const std::string& strategy) {
    const std::string summary_path = work_.path() + "/" + strategy + ".json";
    const int code = RunSim({"--strategy=" + strategy, "--samples=100", "--seed=1",
                             "--summary=" + summary_path},
                            strategy, seconds(240));
    const std::string out = ReadFileOrEmpty(sim_out_);
    ASSERT_EQ(code, 0) << "excite-sim stdout:\n"
                       << out << "\nstderr:\n"
                       << ReadFileOrEmpty(sim_err_) << "\nserver stderr:\n"
                       << ReadFileOrEmpty(server_->stderr_path());
    std::cout << out;  // The run's progress lines, for the test log.
    EXPECT_NE(out.find("step "), std::string::npos);
    EXPECT_NE(out.find("summary written to " + summary_path), std::string::npos);

    const std::string json = ReadFileOrEmpty(summary_path);
    ASSERT_FALSE(json.empty());
    EXPECT_EQ(JsonString(json, "system"), "pendulum");
    EXPECT_EQ(JsonString(json, "strategy"), strategy);
    EXPECT_TRUE(JsonString(json, "session").has_value());
    EXPECT_EQ(JsonNumber(json, "samples"), 100.0);
    for (const char* key :
         {"final_rmse", "coverage_marginal", "coverage_joint", "plan_ms_p50", "wall_s"}) {
      const std::optional<double> value = JsonNumber(json, key);
      ASSERT_TRUE(value.has_value()) << key << " missing or null in\n" << json;
      EXPECT_TRUE(std::isfinite(*value)) << key;
      EXPECT_GE(*value, 0.0) << key;
    }
    EXPECT_GT(*JsonNumber(json, "coverage_marginal"), 0.0);
    EXPECT_LE(*JsonNumber(json, "coverage_marginal"), 1.0);
    EXPECT_LE(*JsonNumber(json, "coverage_joint"), 1.0);

    const std::vector<std::pair<double, double>> history = RmseHistory(json);
    ASSERT_EQ(history.size(), 10u) << json;  // Every 10 of 100 samples.
    EXPECT_EQ(history.front().first, 10.0);
    EXPECT_EQ(history.back().first, 100.0);
    EXPECT_EQ(history.back().second, *JsonNumber(json, "final_rmse"));
    EXPECT_LT(history.back().second, history.front().second) << json;
  }

  // Runs the excite CLI against the server to completion; returns its exit code
  // (-1 if it did not finish) and fills *out / *err with its output.
  int RunCli(const std::vector<std::string>& args, std::string* out, std::string* err) {
    std::vector<std::string> argv = {EXCITE_CLI_PATH, "--server=" + address_};
    argv.insert(argv.end(), args.begin(), args.end());
    const std::string out_path = work_.path() + "/cli.out";
    const std::string err_path = work_.path() + "/cli.err";
    auto cli = Subprocess::Start(argv, out_path, err_path);
    EXPECT_TRUE(cli.ok()) << cli.status();
    if (!cli.ok()) return -1;
    absl::StatusOr<int> code = (*cli)->Wait(seconds(60));
    *out = ReadFileOrEmpty(out_path);
    *err = ReadFileOrEmpty(err_path);
    return code.ok() ? *code : -1;
  }

  TempDir work_{"excite-e2e"};
  std::string data_dir_ = work_.path() + "/data";
  std::unique_ptr<Subprocess> server_;
  std::string address_;
  std::string sim_out_;
  std::string sim_err_;
};

TEST_F(EndToEndTest, PendulumRecReducesRmse) {
  ExploreAndCheck("rec");
  StopServer();
}

TEST_F(EndToEndTest, PendulumPaReducesRmse) {
  ExploreAndCheck("pa");
  StopServer();
}

// `excite export` writes a session to a file, `excite import` brings it back
// (under its own id or --session_id), with its samples.
TEST_F(EndToEndTest, CliExportsAndImportsASession) {
  const std::string trajectory = work_.path() + "/trajectory.csv";
  ASSERT_EQ(RunSim({"--strategy=prbs", "--samples=12", "--seed=2", "--keep_session",
                    "--session_id=cli-src", "--trajectory=" + trajectory},
                   "prbs", seconds(120)),
            0)
      << ReadFileOrEmpty(sim_err_);
  // --trajectory: a header and one row per stored transition, numbered from 0.
  const std::string rows = ReadFileOrEmpty(trajectory);
  // The header names the columns as the config names the dimensions.
  EXPECT_EQ(rows.rfind("theta,theta_dot,tau,theta_next,theta_dot_next,sequence\n", 0), 0u)
      << rows;
  EXPECT_EQ(std::count(rows.begin(), rows.end(), '\n'), 13) << rows;
  EXPECT_NE(rows.find(",0\n"), std::string::npos) << rows;
  EXPECT_NE(rows.find(",11\n"), std::string::npos) << rows;
  std::string out, err;
  // It is what excite add reads: into a new session, all 12 with their numbers,
  // and again, nothing twice.
  ASSERT_EQ(RunCli({"sessions", "create", "--config=" EXCITE_PENDULUM_CONFIG, "--id=csv"},
                   &out, &err),
            0)
      << err;
  ASSERT_EQ(RunCli({"add", "csv", trajectory}, &out, &err), 0) << err;
  EXPECT_NE(out.find("12 stored, 0 already there"), std::string::npos) << out;
  ASSERT_EQ(RunCli({"add", "csv", trajectory}, &out, &err), 0) << err;
  EXPECT_NE(out.find("0 stored, 12 already there"), std::string::npos) << out;
  // A mistyped number is an error naming the line, and nothing is added.
  const std::string typo = work_.path() + "/typo.csv";
  std::ofstream(typo) << "0.1,0.2,O.5,0.1,0.2\n1,2,3,4,5\n2,3,4,5,6\n";
  EXPECT_EQ(RunCli({"add", "csv", typo}, &out, &err), 1);
  EXPECT_NE(err.find("typo.csv: line 1, column 3: \"O.5\" is not a finite number"),
            std::string::npos)
      << err;
  ASSERT_EQ(RunCli({"sessions", "get", "csv"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("sample_count: 12"), std::string::npos) << out;
  const std::string file = work_.path() + "/cli-src.excite";
  ASSERT_EQ(RunCli({"export", "cli-src", file}, &out, &err), 0) << err;
  EXPECT_NE(out.find("exported sessions/cli-src (12 samples"), std::string::npos) << out;
  // JSON: counts are strings, as in every other command's output.
  ASSERT_EQ(RunCli({"--output=json", "export", "cli-src", file}, &out, &err), 0) << err;
  EXPECT_NE(out.find("\"samples\":\"12\""), std::string::npos) << out;
  ASSERT_GT(std::filesystem::file_size(file), 0u);
  ASSERT_EQ(RunCli({"sessions", "delete", "cli-src"}, &out, &err), 0) << err;

  ASSERT_EQ(RunCli({"import", file}, &out, &err), 0) << err;
  EXPECT_NE(out.find("imported sessions/cli-src (12 samples)"), std::string::npos) << out;
  EXPECT_EQ(RunCli({"import", file}, &out, &err), 1);
  EXPECT_NE(err.find("ALREADY_EXISTS"), std::string::npos) << err;
  ASSERT_EQ(RunCli({"import", file, "--id=cli-copy"}, &out, &err), 0) << err;
  ASSERT_EQ(RunCli({"sessions", "get", "cli-copy"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("sample_count: 12"), std::string::npos) << out;
  EXPECT_NE(out.find("last_sequence: 11"), std::string::npos) << out;

  EXPECT_EQ(RunCli({"import", work_.path() + "/no-such-file"}, &out, &err), 1);
  EXPECT_NE(err.find("cannot read"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"export", "cli-src"}, &out, &err), 2);  // usage
  StopServer();
}

// A first workflow with the CLI alone: create a session from a plant's config
// file, add data from CSV, predict and plan, JSON output, and errors in words.
// Ctrl-C stops excite-sim after its current step and says what happened to the
// session; --replace starts anew over a kept one.
TEST_F(EndToEndTest, SimSaysWhatAnInterruptLeavesBehind) {
  const auto interrupted = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> argv = {EXCITE_SIM_PATH, "--server=" + address_,
                                     "--config=" EXCITE_PENDULUM_CONFIG,
                                     "--session_id=ctrl-c", "--samples=5000"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    auto sim =
        Subprocess::Start(argv, work_.path() + "/int.out", work_.path() + "/int.err");
    EXPECT_TRUE(sim.ok()) << sim.status();
    if (!sim.ok()) return std::string();
    // Interrupted once it plans (past the random start).
    EXPECT_TRUE((*sim)->WaitForStdoutLine("step ", seconds(120)).ok());
    (*sim)->Signal(SIGINT);
    absl::StatusOr<int> code = (*sim)->Wait(seconds(120));
    EXPECT_TRUE(code.ok()) << code.status();
    EXPECT_EQ(code.value_or(-1), 1);
    return ReadFileOrEmpty(work_.path() + "/int.err");
  };
  std::string err = interrupted({});
  EXPECT_NE(err.find("interrupted after "), std::string::npos) << err;
  EXPECT_NE(err.find("(the session was deleted)"), std::string::npos) << err;
  EXPECT_NE(err.find("(CANCELLED)"), std::string::npos) << err;
  std::string out, cli_err;
  EXPECT_EQ(RunCli({"sessions", "get", "ctrl-c"}, &out, &cli_err), 1);
  EXPECT_NE(cli_err.find("NOT_FOUND"), std::string::npos) << cli_err;

  err = interrupted({"--keep_session"});
  EXPECT_NE(
      err.find("(the session is kept: continue it with --resume --session_id=ctrl-c)"),
      std::string::npos)
      << err;
  ASSERT_EQ(RunCli({"sessions", "get", "ctrl-c"}, &out, &cli_err), 0) << cli_err;
  // (No std::regex: GCC 12 warns inside it under the sanitizers' build.)
  const size_t at = out.find("sample_count: ");
  ASSERT_NE(at, std::string::npos) << out;
  const int held = std::stoi(out.substr(at + 14));
  // --resume continues it: its samples stay, new ones are numbered after them.
  ASSERT_EQ(
      RunSim({"--session_id=ctrl-c", "--resume", absl::StrCat("--samples=", held + 8)},
             "resume", seconds(120)),
      0)
      << ReadFileOrEmpty(sim_err_);
  EXPECT_NE(ReadFileOrEmpty(sim_out_).find(
                absl::StrCat("resuming sessions/ctrl-c at ", held, " samples")),
            std::string::npos)
      << ReadFileOrEmpty(sim_out_);
  EXPECT_NE(ReadFileOrEmpty(sim_out_).find("session kept: sessions/ctrl-c"),
            std::string::npos);
  ASSERT_EQ(RunCli({"sessions", "get", "ctrl-c"}, &out, &cli_err), 0) << cli_err;
  EXPECT_NE(out.find(absl::StrCat("sample_count: ", held + 8)), std::string::npos) << out;
  EXPECT_NE(out.find(absl::StrCat("last_sequence: ", held + 7)), std::string::npos)
      << out;
  EXPECT_EQ(RunSim({"--session_id=nobody", "--resume", "--samples=12"}, "resume-missing",
                   seconds(120)),
            1);
  EXPECT_NE(
      ReadFileOrEmpty(sim_err_).find("there is no session sessions/nobody to continue"),
      std::string::npos)
      << ReadFileOrEmpty(sim_err_);
  // The same id again: refused, unless --replace.
  EXPECT_EQ(RunSim({"--session_id=ctrl-c", "--samples=12"}, "again", seconds(120)), 1);
  EXPECT_NE(ReadFileOrEmpty(sim_err_).find("ALREADY_EXISTS"), std::string::npos);
  ASSERT_EQ(RunSim({"--session_id=ctrl-c", "--samples=12", "--replace"}, "replace",
                   seconds(120)),
            0)
      << ReadFileOrEmpty(sim_err_);
  EXPECT_NE(ReadFileOrEmpty(sim_out_).find("replaced sessions/ctrl-c"),
            std::string::npos);
  StopServer();
}

TEST_F(EndToEndTest, CliDoesAFirstWorkflowAlone) {
  std::string out, err;
  ASSERT_EQ(
      RunCli({"sessions", "create", "--config=" EXCITE_PENDULUM_CONFIG, "--id=first"},
             &out, &err),
      0)
      << err;  // a SimConfig file: its `session`
  EXPECT_NE(out.find("created sessions/first"), std::string::npos) << out;
  EXPECT_EQ(RunCli({"predict", "--session=first", "--z=0.1,0.2,0.3"}, &out, &err), 1);
  EXPECT_NE(err.find("FAILED_PRECONDITION"), std::string::npos) << err;

  // 40 transitions of a slow linear system, with a header and a comment.
  std::string csv = "theta,omega,u,theta_next,omega_next\n# generated\n";
  for (int i = 0; i < 40; ++i) {
    const double x0 = std::sin(0.3 * i), x1 = std::cos(0.7 * i), u = std::sin(1.1 * i);
    csv += absl::StrCat(x0, ",", x1, ",", u, ",", x0 + 0.05 * x1, ",",
                        x1 + 0.05 * (u - x0), "\n");
  }
  const std::string file = work_.path() + "/data.csv";
  std::ofstream(file) << csv;
  ASSERT_EQ(RunCli({"add", "first", file}, &out, &err), 0) << err;
  EXPECT_NE(out.find("added 40 rows to sessions/first: 40 stored, 0 already there; 40 "
                     "samples"),
            std::string::npos)
      << out;
  // The same rows with their sequence numbers (0-39, as numbered above): stored
  // already, so nothing is stored twice.
  std::string numbered;
  int row = -1;
  for (absl::string_view line : absl::StrSplit(csv, '\n', absl::SkipEmpty())) {
    if (++row >= 2) numbered += absl::StrCat(line, ",", row - 2, "\n");
  }
  std::ofstream(work_.path() + "/numbered.csv") << numbered;
  ASSERT_EQ(RunCli({"--output=json", "add", "first", work_.path() + "/numbered.csv"},
                   &out, &err),
            0)
      << err;
  EXPECT_NE(out.find("\"stored\":\"0\",\"duplicates\":\"40\""), std::string::npos) << out;

  ASSERT_EQ(RunCli({"--output=json", "predict", "first", "--z=0.1,0.2,0.3"}, &out, &err),
            0)
      << err;
  EXPECT_EQ(out.rfind("{\"mean\":[", 0), 0u) << out;
  ASSERT_EQ(RunCli({"--output=json", "sessions", "list"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("\"name\":\"sessions/first\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"sample_count\":\"40\""), std::string::npos) << out;
  ASSERT_EQ(RunCli({"plan", "first", "--state=0,0"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("horizon"), std::string::npos) << out;
  // --session is still understood; twice and different is a usage error.
  ASSERT_EQ(RunCli({"plan", "--session=first", "--state=0,0"}, &out, &err), 0) << err;
  EXPECT_EQ(RunCli({"plan", "first", "--session=other", "--state=0,0"}, &out, &err), 2);
  EXPECT_NE(err.find("the session is given twice"), std::string::npos) << err;
  // The history: both plans, the learning curve from the first fit on.
  ASSERT_EQ(RunCli({"history", "first"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("2 plans; the last at 40 samples"), std::string::npos) << out;
  EXPECT_NE(out.find("per state dimension: theta [rad], theta_dot [rad/s]"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("  40 | "), std::string::npos) << out;  // mean std at the first fit
  ASSERT_EQ(RunCli({"--output=json", "history", "first"}, &out, &err), 0) << err;
  EXPECT_EQ(out.rfind("{\"plans\":[", 0), 0u) << out;
  // A plan after two pending inputs counts its steps from the given state.
  ASSERT_EQ(
      RunCli({"plan", "first", "--state=0,0", "--pending_inputs=0.5,-0.5"}, &out, &err),
      0)
      << err;
  EXPECT_NE(out.find("after the 2 pending one(s)"), std::string::npos) << out;
  EXPECT_NE(out.find("\n   2 | "), std::string::npos) << out;
  EXPECT_EQ(
      RunCli({"plan", "first", "--state=0,0", "--pending_inputs=0.5,x"}, &out, &err), 2);
  // A rollout: step 0 is the state itself, with no spread.
  ASSERT_EQ(
      RunCli({"rollout", "first", "--state=0.1,0", "--inputs=0.5,0.5,0.5"}, &out, &err),
      0)
      << err;
  EXPECT_NE(out.find("state: theta [rad], theta_dot [rad/s]"), std::string::npos) << out;
  EXPECT_NE(out.find("   0 |        0.1          0 |          0          0"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("\n   3 | "), std::string::npos) << out;
  EXPECT_EQ(RunCli({"rollout", "first", "--state=0.1,0"}, &out, &err), 2);  // no inputs
  EXPECT_NE(err.find("--inputs must be"), std::string::npos) << err;
  // The model taken home: a model file that starts as the format says.
  const std::string model_path = work_.path() + "/first.model";
  ASSERT_EQ(RunCli({"export-model", "first", model_path}, &out, &err), 0) << err;
  EXPECT_NE(out.find("model file format 1"), std::string::npos) << out;
  std::string magic(8, '\0');
  std::ifstream(model_path, std::ios::binary).read(magic.data(), 8);
  EXPECT_EQ(magic, "EXCITEMF");
  // A typo gets a suggestion; the version says what was built.
  EXPECT_EQ(RunCli({"pridict", "first"}, &out, &err), 2);
  EXPECT_NE(err.find("unknown command \"pridict\" (did you mean predict?)"),
            std::string::npos)
      << err;
  ASSERT_EQ(RunCli({"--version"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("excite 0."), std::string::npos) << out;
  EXPECT_NE(out.find("(commit "), std::string::npos) << out;
  EXPECT_EQ(out.find("Debug build"), std::string::npos) << out;

  // Sessions a person can tell apart: a display name and labels, and a filter.
  ASSERT_EQ(
      RunCli({"sessions", "create", "--config=" EXCITE_PENDULUM_CONFIG, "--id=second",
              "--display_name=Rig B", "--labels=plant=pendulum,rig=b"},
             &out, &err),
      0)
      << err;
  ASSERT_EQ(RunCli({"sessions", "list", "--filter=labels.rig = b"}, &out, &err), 0)
      << err;
  EXPECT_NE(out.find("sessions/second"), std::string::npos) << out;
  EXPECT_NE(out.find("\"Rig B\""), std::string::npos) << out;
  EXPECT_NE(out.find("labels=plant=pendulum,rig=b"), std::string::npos) << out;
  EXPECT_EQ(out.find("sessions/first"), std::string::npos) << out;
  EXPECT_EQ(
      RunCli({"sessions", "create", "--config=" EXCITE_PENDULUM_CONFIG, "--labels=x"},
             &out, &err),
      2);
  EXPECT_NE(err.find("\"x\" is not KEY=VALUE"), std::string::npos) << err;

  // Local errors are said as such, not as gRPC codes.
  EXPECT_EQ(RunCli({"sessions", "create", "--config=/no/such.textproto"}, &out, &err), 1);
  EXPECT_NE(err.find("excite: cannot read /no/such.textproto"), std::string::npos) << err;
  std::ofstream(work_.path() + "/bad.csv") << "0,0,0,0,0\n1,2,3\n";
  EXPECT_EQ(RunCli({"add", "first", work_.path() + "/bad.csv"}, &out, &err), 1);
  EXPECT_NE(err.find("bad.csv: line 2: want 5 comma-separated numbers"),
            std::string::npos)
      << err;
  EXPECT_EQ(RunCli({"export", "first", "/no/such/dir/x.excite"}, &out, &err), 1);
  EXPECT_EQ(err.find("INVALID_ARGUMENT"), std::string::npos) << err;
  EXPECT_EQ(err.find("NOT_FOUND"), std::string::npos) << err;
  // A server that is not there, in words.
  EXPECT_EQ(
      RunCli({"--server=127.0.0.1:1", "--timeout_s=5", "sessions", "list"}, &out, &err),
      1);
  EXPECT_NE(err.find("cannot reach excite-server at 127.0.0.1:1"), std::string::npos)
      << err;
  StopServer();
}

TEST(EndToEndNoServerTest, SimNamesTheUnreachableAddress) {
  TempDir work("excite-e2e-noserver");
  // Port 1 (tcpmux): nobody listens there on a test machine.
  const std::string address = "127.0.0.1:1";
  auto sim =
      Subprocess::Start({EXCITE_SIM_PATH, "--server=" + address,
                         "--config=" EXCITE_PENDULUM_CONFIG, "--connect_timeout_s=1"},
                        work.path() + "/sim.out", work.path() + "/sim.err");
  ASSERT_TRUE(sim.ok()) << sim.status();
  absl::StatusOr<int> code = (*sim)->Wait(seconds(30));
  ASSERT_TRUE(code.ok()) << code.status();
  EXPECT_NE(*code, 0);
  const std::string err = ReadFileOrEmpty(work.path() + "/sim.err");
  EXPECT_NE(err.find(address), std::string::npos) << err;
}

TEST(EndToEndNoServerTest, SimRejectsUnknownStrategy) {
  TempDir work("excite-e2e-badflag");
  auto sim = Subprocess::Start({EXCITE_SIM_PATH, "--server=127.0.0.1:1",
                                "--config=" EXCITE_PENDULUM_CONFIG, "--strategy=bogus"},
                               work.path() + "/sim.out", work.path() + "/sim.err");
  ASSERT_TRUE(sim.ok()) << sim.status();
  absl::StatusOr<int> code = (*sim)->Wait(seconds(30));
  ASSERT_TRUE(code.ok()) << code.status();
  EXPECT_NE(*code, 0);
  EXPECT_NE(ReadFileOrEmpty(work.path() + "/sim.err").find("bogus"), std::string::npos);
}

// `--help` of each program lists that program's own flags and exits 0 (it used
// to print "No flags matched." and exit 1).
// On a CPU with AVX2 and FMA the server runs OpenBLAS's kernels for it, also where
// OpenBLAS does not know the CPU's model and falls back to Prescott's (this
// machine kind: server/blas/cpu_kernels.h); a user's OPENBLAS_CORETYPE is kept.
TEST(EndToEndNoServerTest, ServerRunsTheCpusOpenBlasKernels) {
  TempDir work("excite-e2e-kernels");
  auto server =
      Subprocess::Start({EXCITE_SERVER_PATH, "--listen=127.0.0.1:0",
                         "--data_dir=" + work.path() + "/data", "--log_level=debug"},
                        work.path() + "/server.out", work.path() + "/server.err");
  ASSERT_TRUE(server.ok()) << server.status();
  ASSERT_TRUE((*server)->WaitForStdoutLine(kListeningPrefix, seconds(30)).ok());
  (*server)->Signal(SIGTERM);
  ASSERT_TRUE((*server)->Wait(seconds(30)).ok());
  const std::string log = ReadFileOrEmpty((*server)->stderr_path());
  const size_t at = log.find("OpenBLAS kernels: ");
  if (at == std::string::npos) GTEST_SKIP() << "the BLAS is not OpenBLAS";
  const std::string core = log.substr(at + 18, log.find('\n', at) - at - 18);
  if (const char* set = std::getenv("OPENBLAS_CORETYPE"); set != nullptr) {
    EXPECT_EQ(absl::AsciiStrToLower(core), absl::AsciiStrToLower(set));
  } else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
    EXPECT_NE(core, "Prescott") << log;
  }
}

TEST(EndToEndNoServerTest, HelpListsEachProgramsFlagsAndExitsZero) {
  TempDir work("excite-e2e-help");
  const std::vector<std::pair<std::string, std::vector<std::string>>> programs = {
      {EXCITE_SERVER_PATH,
       {"--listen", "--data_dir", "--memory_budget_mb", "--planner_workers"}},
      {EXCITE_SIM_PATH, {"--config", "--strategy", "--server", "--tls_ca"}},
      {EXCITE_CLI_PATH, {"--server", "--config", "--timeout_s", "sessions list"}}};
  for (const auto& [path, expected] : programs) {
    auto program = Subprocess::Start({path, "--help"}, work.path() + "/help.out",
                                     work.path() + "/help.err");
    ASSERT_TRUE(program.ok()) << program.status();
    absl::StatusOr<int> code = (*program)->Wait(seconds(30));
    ASSERT_TRUE(code.ok()) << code.status();
    EXPECT_EQ(*code, 0) << path;
    const std::string out = ReadFileOrEmpty(work.path() + "/help.out");
    for (const std::string& text : expected) {
      EXPECT_NE(out.find(text), std::string::npos) << path << " --help lacks " << text;
    }
    EXPECT_EQ(out.find("No flags matched"), std::string::npos) << out;
    EXPECT_EQ(out.find("--flagfile"), std::string::npos) << "Abseil's own flags: " << out;
  }
}

}  // namespace
}  // namespace excite::testing
