// gp_fit_once: one ML-II fit of one output, as excite's service runs a cold fit
// (FitHyperparameters from the data-driven default start plus FitOptions' random
// restarts), on data read from a file, printing one JSON line. bench/gp/
// fit_vs_sklearn.py runs it beside scikit-learn on the same data and bounds.
//
// Data file: first line "n d", then n lines of d inputs and 1 target, already
// normalised (what the service fits on).

#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>

#include "absl/flags/flag.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/usage.h"
#include "server/blas/cpu_kernels.h"
#include "server/gp/gp_model.h"
#include "server/gp/hyperparameter_fit.h"

ABSL_FLAG(std::string, data, "", "Data file (see the top of fit_once.cc).");
ABSL_FLAG(double, min_lengthscale, excite::gp::FitOptions{}.min_lengthscale, "");
ABSL_FLAG(double, max_lengthscale, excite::gp::FitOptions{}.max_lengthscale, "");
ABSL_FLAG(double, min_signal_variance, excite::gp::FitOptions{}.min_signal_variance, "");
ABSL_FLAG(double, max_signal_variance, excite::gp::FitOptions{}.max_signal_variance, "");
ABSL_FLAG(double, min_noise_variance, excite::gp::FitOptions{}.min_noise_variance, "");
ABSL_FLAG(double, max_noise_variance, excite::gp::FitOptions{}.max_noise_variance, "");
ABSL_FLAG(int, restarts, excite::gp::FitOptions{}.restarts, "");
ABSL_FLAG(int, presearch_size, excite::gp::FitOptions{}.presearch_size, "");
ABSL_FLAG(int, predict_points, 0,
          "After the fit, time a prediction (mean and variance) at this many points "
          "drawn uniformly from [-1, 1]^d.");
ABSL_FLAG(double, reactivate_above, excite::gp::FitOptions{}.reactivate_above, "");
ABSL_FLAG(int, max_iterations, excite::gp::FitOptions{}.max_iterations, "");
ABSL_FLAG(double, gradient_tolerance, excite::gp::FitOptions{}.gradient_tolerance, "");
ABSL_FLAG(double, function_tolerance, excite::gp::FitOptions{}.function_tolerance, "");

namespace excite::gp {
namespace {

int Run() {
  std::ifstream in(absl::GetFlag(FLAGS_data));
  int n = 0, d = 0;
  if (!(in >> n >> d) || n < 1 || d < 1) {
    std::fprintf(stderr, "gp_fit_once: cannot read 'n d' from --data\n");
    return 2;
  }
  Eigen::MatrixXd x(n, d);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    for (int l = 0; l < d; ++l) in >> x(i, l);
    in >> y(i);
  }
  if (!in) {
    std::fprintf(stderr, "gp_fit_once: --data has fewer than %d rows of %d numbers\n", n,
                 d + 1);
    return 2;
  }
  FitOptions options;
  options.min_lengthscale = absl::GetFlag(FLAGS_min_lengthscale);
  options.max_lengthscale = absl::GetFlag(FLAGS_max_lengthscale);
  options.min_signal_variance = absl::GetFlag(FLAGS_min_signal_variance);
  options.max_signal_variance = absl::GetFlag(FLAGS_max_signal_variance);
  options.min_noise_variance = absl::GetFlag(FLAGS_min_noise_variance);
  options.max_noise_variance = absl::GetFlag(FLAGS_max_noise_variance);
  options.restarts = absl::GetFlag(FLAGS_restarts);
  options.max_iterations = absl::GetFlag(FLAGS_max_iterations);
  options.presearch_size = absl::GetFlag(FLAGS_presearch_size);
  options.reactivate_above = absl::GetFlag(FLAGS_reactivate_above);
  options.gradient_tolerance = absl::GetFlag(FLAGS_gradient_tolerance);
  options.function_tolerance = absl::GetFlag(FLAGS_function_tolerance);

  const auto t0 = std::chrono::steady_clock::now();
  Hyperparameters start;  // what the service starts a cold fit from
  start.signal_variance = 1.0;
  start.lengthscales = Eigen::VectorXd::Ones(d);
  start.noise_variance = std::max(options.min_noise_variance, 1e-2);
  GpModel model;
  if (absl::Status s = model.Reset(x, y, start); !s.ok()) {
    std::fprintf(stderr, "gp_fit_once: %s\n", s.ToString().c_str());
    return 1;
  }
  absl::StatusOr<FitSummary> fit = FitHyperparameters(
      options, options.min_noise_variance, /*fit_noise=*/true, std::nullopt, &model);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!fit.ok()) {
    std::fprintf(stderr, "gp_fit_once: %s\n", fit.status().ToString().c_str());
    return 1;
  }
  const int m = absl::GetFlag(FLAGS_predict_points);
  double predict_seconds = 0.0;
  if (m > 0) {
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd xs(m, d);
    for (int i = 0; i < m; ++i) {
      for (int l = 0; l < d; ++l) xs(i, l) = uniform(rng);
    }
    Eigen::VectorXd mean, variance;
    const auto p0 = std::chrono::steady_clock::now();
    model.Predict(xs, &mean, &variance, nullptr, nullptr);
    predict_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - p0).count();
  }
  const Hyperparameters& h = model.hyperparameters();
  const std::string json = absl::StrCat(
      "{\"predict_seconds\": ", predict_seconds, ", ", "\"seconds\": ", seconds,
      ", \"lml\": ", model.log_marginal_likelihood(),
      ", \"evaluations\": ", fit->evaluations,
      ", \"presearch_evaluations\": ", fit->presearch_evaluations,
      ", \"iterations\": ", fit->iterations, ", \"starts\": ", fit->starts,
      ", \"signal_variance\": ", h.signal_variance,
      ", \"noise_variance\": ", h.noise_variance, ", \"lengthscales\": [",
      absl::StrJoin(h.lengthscales.data(), h.lengthscales.data() + d, ", "), "]}");
  std::printf("%s\n", json.c_str());
  return 0;
}

}  // namespace
}  // namespace excite::gp

int main(int argc, char** argv) {
  excite::blas::RunAgainWithTheCpusBlasKernels(argv);  // as the server
  excite::ParseFlags(argc, argv,
                     "gp_fit_once --data=FILE [--min_lengthscale=...]: one cold ML-II "
                     "fit, printed as JSON");
  return excite::gp::Run();
}
