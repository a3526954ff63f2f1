#include "server/blas/blas_lock.h"

#include <dlfcn.h>

namespace excite::blas {

bool BlasNeedsSerialising() {
  // Every OpenBLAS build exports openblas_get_config(); BLIS and the reference
  // BLAS do not.
  static const bool openblas = dlsym(RTLD_DEFAULT, "openblas_get_config") != nullptr;
  return openblas;
}

std::recursive_mutex& BlasMutex() {
  static std::recursive_mutex* const mutex = new std::recursive_mutex;
  return *mutex;
}

BlasLock::BlasLock() {
  if (BlasNeedsSerialising()) lock_ = std::unique_lock<std::recursive_mutex>(BlasMutex());
}

absl::Status CheckBlasRunsOnTheCallingThread() {
  // OpenBLAS's threaded builds define openblas_get_parallel() != 0; other BLAS
  // libraries do not define it.
  using GetParallel = int (*)();
  const auto get_parallel =
      reinterpret_cast<GetParallel>(dlsym(RTLD_DEFAULT, "openblas_get_parallel"));
  if (get_parallel == nullptr || get_parallel() == 0) return absl::OkStatus();
  return absl::FailedPreconditionError(
      "the system's BLAS is a threaded OpenBLAS (libopenblas0-pthread or -openmp). It "
      "starts threads before main() that take SIGTERM, and its 60 KB of static TLS "
      "overflows the metrics server's thread stacks. Select the serial build: apt-get "
      "install libopenblas0-serial, then update-alternatives --set "
      "libblas.so.3-x86_64-linux-gnu "
      "/usr/lib/x86_64-linux-gnu/openblas-serial/libblas.so.3 and the same for "
      "liblapack.so.3 (scripts/setup.sh does both)");
}

}  // namespace excite::blas
