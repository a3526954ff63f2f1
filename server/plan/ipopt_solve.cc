#include "server/plan/ipopt_solve.h"

#include <IpIpoptApplication.hpp>
#include <IpJournalist.hpp>
#include <IpUtils.hpp>
#include <chrono>
#include <exception>
#include <mutex>
#include <optional>
#include <sstream>

#include "server/blas/blas_lock.h"
#include "server/plan/ipopt_library_calls.h"

// Ipopt 3.11 times its internal tasks with CpuTime() and SysTime(), each a
// getrusage system call, expensive on these virtual machines, also when no timing
// statistics are asked for; its adaptive barrier update times every trial of its
// golden-section search. These definitions replace the library's (libipopt calls
// them through its PLT, so the executable's win): a monotonic clock read in user
// space, and no system time. Ipopt reads them only for its timing statistics and
// max_cpu_time, which excite does not set (and which thus counts wall time). The
// plans are unchanged; a pendulum rec step at n = 100-300, mostly Ipopt's own
// work, takes a quarter less time (README, "Measured numbers").
namespace Ipopt {
Number CpuTime() {
  return std::chrono::duration<Number>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
Number SysTime() { return 0.0; }
}  // namespace Ipopt

namespace excite::plan {

IpoptOutcome SolveTnlp(const Ipopt::SmartPtr<Ipopt::TNLP>& nlp,
                       const IpoptSettings& settings) {
  IpoptOutcome outcome;
  std::ostringstream captured;
  // Serial only if the per-call wrappers are not in effect (see
  // IpoptLibraryCallsAreWrapped()).
  std::unique_lock<std::recursive_mutex> whole_solve;
  std::optional<blas::BlasLock> whole_solve_blas;
  if (!IpoptLibraryCallsAreWrapped()) {
    whole_solve = std::unique_lock<std::recursive_mutex>(MumpsMutex());
    whole_solve_blas.emplace();
  }
  try {
    Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication();
    Ipopt::SmartPtr<Ipopt::OptionsList> options = app->Options();
    bool ok = true;
    ok &= options->SetStringValue("option_file_name", "");
    ok &= options->SetStringValue("sb", "yes");
    ok &= options->SetIntegerValue("print_level", 0);
    ok &= options->SetStringValue("hessian_approximation", "limited-memory");
    ok &= options->SetIntegerValue("max_iter", settings.max_iterations);
    ok &= options->SetNumericValue("tol", settings.tolerance);
    ok &= options->SetNumericValue("obj_scaling_factor", settings.objective_scaling);
    for (const auto& [name, value] : settings.string_options) {
      ok &= options->SetStringValue(name, value);
    }
    for (const auto& [name, value] : settings.integer_options) {
      ok &= options->SetIntegerValue(name, value);
    }
    for (const auto& [name, value] : settings.numeric_options) {
      ok &= options->SetNumericValue(name, value);
    }
    outcome.options_accepted = ok;
    if (settings.log != nullptr) {
      Ipopt::SmartPtr<Ipopt::StreamJournal> journal = new Ipopt::StreamJournal(
          "excite_capture", static_cast<Ipopt::EJournalLevel>(settings.log_level));
      journal->SetOutputStream(&captured);
      app->Jnlst()->AddJournal(Ipopt::GetRawPtr(journal));
    }
    // An empty stream: Initialize() must not look for ipopt.opt in the cwd.
    std::istringstream no_option_file;
    outcome.status = app->Initialize(no_option_file);
    if (outcome.status == Ipopt::Solve_Succeeded) {
      outcome.status = app->OptimizeTNLP(nlp);
    }
    app->Jnlst()->FlushBuffer();
  } catch (const std::exception&) {
    outcome.status = Ipopt::NonIpopt_Exception_Thrown;
  } catch (...) {
    outcome.status = Ipopt::NonIpopt_Exception_Thrown;
  }
  if (settings.log != nullptr) settings.log->append(captured.str());
  return outcome;
}

}  // namespace excite::plan
