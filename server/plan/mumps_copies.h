#ifndef EXCITE_SERVER_PLAN_MUMPS_COPIES_H_
#define EXCITE_SERVER_PLAN_MUMPS_COPIES_H_

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace excite::plan {

// MUMPS keeps its state in process globals (Fortran module variables, its
// sequential MPI stub), so one copy of the library serves one call at a time
// (coin-or/Ipopt#733). MumpsCopies lets solves factorise in parallel anyway: beside
// the process's own copy it loads more with dlmopen, each into a link namespace of
// its own, with its own MUMPS, gfortran and BLAS globals (the copy's BLAS calls go
// to its own OpenBLAS, not to the process's). A copy is added when every loaded one
// is in use by a solve, up to `max_copies`; a MUMPS instance (the struct Ipopt's
// linear solver passes) stays on the copy that started it (job -1) until it ends
// (job -2), and each copy runs one call at a time under its own lock. A copy that
// cannot be loaded (glibc's static TLS or namespace limit) is logged once; solves
// then share the loaded ones.
class MumpsCopies {
 public:
  using Entry = void (*)(void*);
  // own: the process's dmumps_c, run under own_lock; the others are loaded from
  // the file that defines it.
  MumpsCopies(Entry own, std::recursive_mutex* own_lock, int max_copies);

  // dmumps_c on the copy `mumps` (a DMUMPS_STRUC_C) belongs to.
  void Call(void* mumps);

  struct Totals {
    int64_t calls = 0;
    double wait_seconds = 0;  // waiting for a copy's lock
    double held_seconds = 0;  // inside MUMPS
    int copies = 0;           // loaded, the process's own included
  };
  Totals ReadTotals() const;

 private:
  struct Copy {
    Entry entry;
    std::recursive_mutex* lock;
    int instances = 0;  // MUMPS instances started on it and not ended
  };
  Copy* Bind(void* mumps);
  void Unbind(void* mumps);
  Copy* Find(void* mumps);
  Copy* LoadCopy();  // under mutex_; null if it cannot be loaded

  const int max_copies_;
  std::string library_;  // the file of the process's own dmumps_c
  mutable std::mutex mutex_;
  std::deque<Copy> copies_;  // stable addresses
  std::deque<std::unique_ptr<std::recursive_mutex>> locks_;
  std::unordered_map<void*, Copy*> bound_;
  bool load_failed_ = false;
  std::atomic<int64_t> calls_{0};
  std::atomic<int64_t> wait_ns_{0};
  std::atomic<int64_t> held_ns_{0};
};

}  // namespace excite::plan

#endif  // EXCITE_SERVER_PLAN_MUMPS_COPIES_H_
