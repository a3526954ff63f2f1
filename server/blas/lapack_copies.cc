#include "server/blas/lapack_copies.h"

#include <dlfcn.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <string>

#include "server/blas/blas_lock.h"

// The process's own definitions (the executable's wrappers where it has them).
extern "C" {
void dpotrf_(const char*, const int*, double*, const int*, int*, std::size_t);
void dpotri_(const char*, const int*, double*, const int*, int*, std::size_t);
void dtrtrs_(const char*, const char*, const char*, const int*, const int*, const double*,
             const int*, double*, const int*, int*, std::size_t, std::size_t,
             std::size_t);
}

namespace excite::blas {
namespace {

constexpr int kMaxCopies = 4;

struct Copy {
  LapackRoutines routines;
  std::mutex lock;
};

class Copies {
 public:
  // A copy locked for the caller: a free one, a new one, or (all in use, none
  // more to load) the next in turn once free. Null if none could be loaded.
  Copy* Take(std::unique_lock<std::mutex>* held) {
    const int loaded = loaded_.load(std::memory_order_acquire);
    for (int i = 0; i < loaded; ++i) {
      std::unique_lock<std::mutex> lock(copies_[i].lock, std::try_to_lock);
      if (lock.owns_lock()) {
        *held = std::move(lock);
        return &copies_[i];
      }
    }
    {
      const std::lock_guard<std::mutex> loading(loading_);
      const int now = loaded_.load(std::memory_order_relaxed);
      if (now < kMaxCopies && !load_failed_ && Load(&copies_[now])) {
        *held = std::unique_lock<std::mutex>(copies_[now].lock);
        loaded_.store(now + 1, std::memory_order_release);
        return &copies_[now];
      }
    }
    const int count = loaded_.load(std::memory_order_acquire);
    if (count == 0) return nullptr;
    Copy* const next = &copies_[turn_.fetch_add(1, std::memory_order_relaxed) % count];
    *held = std::unique_lock<std::mutex>(next->lock);
    return next;
  }

  int loaded() const { return loaded_.load(std::memory_order_acquire); }

 private:
  // Under loading_.
  bool Load(Copy* copy) {
    const char* problem = "the file defining dpotrf_ is unknown";
    Dl_info info;
    void* const own = dlsym(RTLD_NEXT, "dpotrf_");  // the library's, not a wrapper
    if (own != nullptr && dladdr(own, &info) != 0 && info.dli_fname != nullptr) {
      void* const handle = dlmopen(LM_ID_NEWLM, info.dli_fname, RTLD_NOW | RTLD_LOCAL);
      if (handle != nullptr) {
        copy->routines.dpotrf =
            reinterpret_cast<decltype(LapackRoutines::dpotrf)>(dlsym(handle, "dpotrf_"));
        copy->routines.dpotri =
            reinterpret_cast<decltype(LapackRoutines::dpotri)>(dlsym(handle, "dpotri_"));
        copy->routines.dtrtrs =
            reinterpret_cast<decltype(LapackRoutines::dtrtrs)>(dlsym(handle, "dtrtrs_"));
        if (copy->routines.dpotrf != nullptr && copy->routines.dpotri != nullptr &&
            copy->routines.dtrtrs != nullptr) {
          return true;
        }
        problem = "a routine is missing in the copy";
      } else {
        problem = dlerror();
      }
    }
    load_failed_ = true;
    std::fprintf(stderr,
                 "excite: could not load copy %d of LAPACK (%s); the GP's "
                 "factorisations share the %d loaded\n",
                 loaded() + 1, problem == nullptr ? "unknown" : problem, loaded());
    return false;
  }

  std::array<Copy, kMaxCopies> copies_;
  std::atomic<int> loaded_{0};
  std::atomic<unsigned> turn_{0};
  std::mutex loading_;
  bool load_failed_ = false;  // under loading_
};

Copies& TheCopies() {
  static Copies* const copies = new Copies;
  return *copies;
}

const LapackRoutines kOwn = {&dpotrf_, &dpotri_, &dtrtrs_};

}  // namespace

LapackTurn::LapackTurn() {
  if (!BlasNeedsSerialising()) {
    routines_ = &kOwn;
    return;
  }
  if (Copy* const copy = TheCopies().Take(&copy_); copy != nullptr) {
    routines_ = &copy->routines;
    return;
  }
  own_ = std::unique_lock<std::recursive_mutex>(BlasMutex());
  routines_ = &kOwn;
}

int LoadedLapackCopies() { return BlasNeedsSerialising() ? TheCopies().loaded() : 0; }

}  // namespace excite::blas
