#include "server/blas/cpu_kernels.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>

namespace excite::blas {

std::string OpenBlasCore() {
  using CoreName = char* (*)();
  const auto core_name =
      reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (core_name == nullptr) return "";  // not OpenBLAS
  const char* chosen = core_name();
  return chosen == nullptr ? "" : chosen;
}

std::string BetterOpenBlasCore() {
  if (OpenBlasCore() != "Prescott") return "";
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512cd") &&
      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512vl")) {
    return "SkylakeX";
  }
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "Haswell";
  return "";
}

void RunAgainWithTheCpusBlasKernels(char** argv) {
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return;
  const std::string core = BetterOpenBlasCore();
  if (core.empty()) return;
  if (setenv("OPENBLAS_CORETYPE", core.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  unsetenv("OPENBLAS_CORETYPE");  // exec failed: run on with the kernels loaded
}

}  // namespace excite::blas
