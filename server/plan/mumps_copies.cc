#include "server/plan/mumps_copies.h"

#include <dlfcn.h>
#include <dmumps_c.h>

#include <chrono>
#include <cstdio>

namespace excite::plan {
namespace {

using Clock = std::chrono::steady_clock;

int64_t Nanoseconds(Clock::duration duration) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(duration).count();
}

}  // namespace

MumpsCopies::MumpsCopies(Entry own, std::recursive_mutex* own_lock, int max_copies)
    : max_copies_(max_copies) {
  copies_.push_back(Copy{own, own_lock});
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(own), &info) != 0 && info.dli_fname != nullptr) {
    library_ = info.dli_fname;
  }
}

MumpsCopies::Copy* MumpsCopies::LoadCopy() {
  const char* problem = "the file defining dmumps_c is unknown";
  if (!library_.empty()) {
    void* const handle = dlmopen(LM_ID_NEWLM, library_.c_str(), RTLD_NOW | RTLD_LOCAL);
    void* const entry = handle == nullptr ? nullptr : dlsym(handle, "dmumps_c");
    if (entry != nullptr) {
      locks_.push_back(std::make_unique<std::recursive_mutex>());
      return &copies_.emplace_back(
          Copy{reinterpret_cast<Entry>(entry), locks_.back().get()});
    }
    problem = dlerror();
  }
  load_failed_ = true;
  std::fprintf(stderr,
               "excite: could not load copy %zu of MUMPS (%s); concurrent solves share "
               "the %zu loaded\n",
               copies_.size() + 1, problem == nullptr ? "no dmumps_c" : problem,
               copies_.size());
  return nullptr;
}

MumpsCopies::Copy* MumpsCopies::Bind(void* mumps) {
  const std::lock_guard<std::mutex> pool(mutex_);
  Copy* chosen = nullptr;
  for (Copy& copy : copies_) {
    if (copy.instances == 0) {
      chosen = &copy;
      break;
    }
  }
  if (chosen == nullptr && !load_failed_ &&
      static_cast<int>(copies_.size()) < max_copies_) {
    chosen = LoadCopy();
  }
  if (chosen == nullptr) {  // all in use: the least used
    chosen = &copies_.front();
    for (Copy& copy : copies_) {
      if (copy.instances < chosen->instances) chosen = &copy;
    }
  }
  Copy*& slot = bound_[mumps];
  if (slot != nullptr) --slot->instances;  // restarted without an end
  slot = chosen;
  ++chosen->instances;
  return chosen;
}

void MumpsCopies::Unbind(void* mumps) {
  const std::lock_guard<std::mutex> pool(mutex_);
  const auto found = bound_.find(mumps);
  if (found == bound_.end()) return;
  --found->second->instances;
  bound_.erase(found);
}

MumpsCopies::Copy* MumpsCopies::Find(void* mumps) {
  const std::lock_guard<std::mutex> pool(mutex_);
  const auto found = bound_.find(mumps);
  // Not started through here: the process's own copy, as without copies.
  return found == bound_.end() ? &copies_.front() : found->second;
}

void MumpsCopies::Call(void* mumps) {
  auto* const structure = static_cast<DMUMPS_STRUC_C*>(mumps);
  const int job = structure->job;
  Copy* const copy = job == -1 ? Bind(mumps) : Find(mumps);
  const auto asked = Clock::now();
  {
    const std::lock_guard<std::recursive_mutex> lock(*copy->lock);
    const auto taken = Clock::now();
    copy->entry(mumps);
    held_ns_.fetch_add(Nanoseconds(Clock::now() - taken), std::memory_order_relaxed);
    wait_ns_.fetch_add(Nanoseconds(taken - asked), std::memory_order_relaxed);
  }
  calls_.fetch_add(1, std::memory_order_relaxed);
  // A start that failed leaves no instance to end.
  if (job == -2 || (job == -1 && structure->infog[0] < 0)) Unbind(mumps);
}

MumpsCopies::Totals MumpsCopies::ReadTotals() const {
  Totals totals;
  totals.calls = calls_.load(std::memory_order_relaxed);
  totals.wait_seconds =
      static_cast<double>(wait_ns_.load(std::memory_order_relaxed)) * 1e-9;
  totals.held_seconds =
      static_cast<double>(held_ns_.load(std::memory_order_relaxed)) * 1e-9;
  const std::lock_guard<std::mutex> pool(mutex_);
  totals.copies = static_cast<int>(copies_.size());
  return totals;
}

}  // namespace excite::plan
