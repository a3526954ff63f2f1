#ifndef EXCITE_SERVER_PLAN_IPOPT_SOLVE_H_
#define EXCITE_SERVER_PLAN_IPOPT_SOLVE_H_

#include <IpTNLP.hpp>
#include <string>
#include <utility>
#include <vector>

namespace excite::plan {

// Options of one Ipopt solve. Everything is passed in code: no ipopt.opt is read,
// nothing is printed (print_level 0, no banner) unless `log` asks for it. Linking
// this file replaces Ipopt's CPU clock with a monotonic one (ipopt_solve.cc), so
// max_cpu_time counts wall time.
struct IpoptSettings {
  int max_iterations = 100;  // max_iter
  double tolerance = 1e-4;   // tol
  // obj_scaling_factor: Ipopt minimises this times f (on top of its own
  // gradient-based scaling, which only ever scales down).
  double objective_scaling = 1.0;
  // Applied after the defaults above and below (e.g. derivative_test).
  std::vector<std::pair<std::string, std::string>> string_options;
  std::vector<std::pair<std::string, int>> integer_options;
  std::vector<std::pair<std::string, double>> numeric_options;
  // If not null, Ipopt's output up to `log_level` (an Ipopt::EJournalLevel,
  // 0..12; 3 = summary, 4 = warnings incl. derivative-checker errors, 5 = one
  // line per iteration) is appended here.
  std::string* log = nullptr;
  int log_level = 4;
};

struct IpoptOutcome {
  Ipopt::ApplicationReturnStatus status = Ipopt::Internal_Error;
  bool options_accepted = true;  // false if Ipopt refused an option
};

// Creates an IpoptApplication, sets `settings` (hessian_approximation =
// limited-memory), solves `nlp` and destroys the application. Solves on other
// threads run at the same time (their MUMPS and BLAS calls take turns:
// ipopt_library_calls.h). Never throws: exceptions become NonIpopt_Exception_Thrown.
IpoptOutcome SolveTnlp(const Ipopt::SmartPtr<Ipopt::TNLP>& nlp,
                       const IpoptSettings& settings);

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_IPOPT_SOLVE_H_
