#ifndef EXCITE_SERVER_GP_FLUSH_DENORMALS_H_
#define EXCITE_SERVER_GP_FLUSH_DENORMALS_H_

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace excite::gp {

// While alive, the calling thread flushes subnormal results to zero and reads
// subnormal operands as zero (x86 SSE: FTZ and DAZ; a no-op elsewhere). A GP
// whose data spans many orders of magnitude produces kernel values below 1e-308
// (exp(-d^2/2) for d^2 > 1416) and their products in the Cholesky factor; they
// carry nothing a 1e-308 does not, but each operation on one costs ~100 times a
// normal one, which turned a 5 ms refit into seconds. Restores the previous mode.
class ScopedFlushDenormals {
 public:
#if defined(__SSE__)
  ScopedFlushDenormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | kFtzDaz); }
  ~ScopedFlushDenormals() { _mm_setcsr(saved_); }
#else
  ScopedFlushDenormals() = default;
#endif
  ScopedFlushDenormals(const ScopedFlushDenormals&) = delete;
  ScopedFlushDenormals& operator=(const ScopedFlushDenormals&) = delete;

 private:
#if defined(__SSE__)
  static constexpr unsigned kFtzDaz = 0x8040;  // MXCSR bits 15 (FTZ) and 6 (DAZ)
  unsigned saved_;
#endif
};

}  // namespace excite::gp

#endif  // EXCITE_SERVER_GP_FLUSH_DENORMALS_H_
