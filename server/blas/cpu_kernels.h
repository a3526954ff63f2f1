#ifndef EXCITE_SERVER_BLAS_CPU_KERNELS_H_
#define EXCITE_SERVER_BLAS_CPU_KERNELS_H_

#include <string>

namespace excite::blas {

// OpenBLAS picks its kernels from the CPU's model number when it is loaded, before
// main(). A CPU whose model it does not know (a virtual machine's "Intel(R) Xeon(R)
// Processor" with AVX-512, on the machines excite is built on) gets its Prescott
// (SSE3) kernels: an ML-II step at n = 1000 then takes 2x, at n = 2000 2.4x, the
// time of the AVX-512 kernels the CPU runs (bench/gp, docs/parallel-planning.md).
// OPENBLAS_CORETYPE overrides the choice, read at load time too.

// The kernels the OpenBLAS loaded uses ("Prescott", "Haswell", "SkylakeX", "Zen",
// ...), or "" for another BLAS.
std::string OpenBlasCore();

// The kernels OpenBLAS should use instead of the ones it chose: "SkylakeX" (the
// CPU has AVX-512 F, CD, BW, DQ and VL) or "Haswell" (AVX2 and FMA) when the
// OpenBLAS loaded fell back to "Prescott"; "" otherwise (another BLAS, a known CPU,
// or an older one).
std::string BetterOpenBlasCore();

// Runs the program again (execv of /proc/self/exe, same process, arguments and
// environment) with OPENBLAS_CORETYPE set to BetterOpenBlasCore(), when that names
// kernels and OPENBLAS_CORETYPE is not set already (a user's choice is kept). Call it
// first in main(), before any thread starts. Returns if nothing is to be done, or if
// the exec failed (the program then runs on as it is).
void RunAgainWithTheCpusBlasKernels(char** argv);

}  // namespace excite::blas

#endif  // EXCITE_SERVER_BLAS_CPU_KERNELS_H_
