// Plan slots: no more plans hold one at once than the limit, a plan inside a plan
// takes none, and a wait ends at the deadline or a cancel without a slot.

#include "server/plan/plan_slots.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "gtest/gtest.h"

namespace excite::plan {
namespace {

using Clock = std::chrono::steady_clock;

// `limit` threads each get a slot and hold it together; one more does not get one
// until they give theirs back.
TEST(PlanSlotsTest, TheLimitHoldSlotsTogetherAndNoMore) {
  for (const int limit : {1, 2, 3}) {
    SetConcurrentPlans(limit);
    EXPECT_EQ(ConcurrentPlans(), limit);
    std::atomic<int> holding{0};
    std::atomic<bool> release{false};
    std::vector<std::thread> threads;
    for (int t = 0; t < limit; ++t) {
      threads.emplace_back([&] {
        PlanSlot slot;
        EXPECT_TRUE(slot.Acquire(Clock::now() + std::chrono::seconds(30), nullptr).ok());
        ++holding;
        while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      });
    }
    const auto give_up = Clock::now() + std::chrono::seconds(30);
    while (holding < limit && Clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_EQ(holding.load(), limit);
    {
      PlanSlot extra;
      EXPECT_TRUE(absl::IsDeadlineExceeded(
          extra.Acquire(Clock::now() + std::chrono::milliseconds(50), nullptr)));
    }
    release = true;
    for (std::thread& t : threads) t.join();
    PlanSlot after;
    EXPECT_TRUE(after.Acquire(Clock::now() + std::chrono::seconds(30), nullptr).ok());
  }
  SetConcurrentPlans(0);  // at least one
  EXPECT_EQ(ConcurrentPlans(), 1);
}

// Many threads taking and giving slots: never more held at once than the limit.
TEST(PlanSlotsTest, NeverMoreThanTheLimitUnderContention) {
  SetConcurrentPlans(2);
  std::atomic<int> holding{0};
  std::atomic<int> most{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t) {
    threads.emplace_back([&] {
      for (int round = 0; round < 20; ++round) {
        PlanSlot slot;
        ASSERT_TRUE(slot.Acquire(std::nullopt, nullptr).ok());
        const int now = ++holding;
        int seen = most.load();
        while (now > seen && !most.compare_exchange_weak(seen, now)) {
        }
        std::this_thread::sleep_for(std::chrono::microseconds(500));
        --holding;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_LE(most.load(), 2);
  EXPECT_GE(most.load(), 1);
}

TEST(PlanSlotsTest, APlanInsideAPlanUsesItsCallersSlot) {
  SetConcurrentPlans(1);
  PlanSlot outer;
  ASSERT_TRUE(outer.Acquire(std::nullopt, nullptr).ok());
  {
    PlanSlot inner;  // would wait forever if it needed a second slot
    EXPECT_TRUE(
        inner.Acquire(Clock::now() + std::chrono::milliseconds(50), nullptr).ok());
  }
  // The inner one gave nothing back: another thread still finds no slot.
  std::thread other([] {
    PlanSlot slot;
    EXPECT_TRUE(absl::IsDeadlineExceeded(
        slot.Acquire(Clock::now() + std::chrono::milliseconds(50), nullptr)));
  });
  other.join();
}

TEST(PlanSlotsTest, AWaitEndsAtTheDeadlineOrACancel) {
  SetConcurrentPlans(1);
  PlanSlot held;
  ASSERT_TRUE(held.Acquire(std::nullopt, nullptr).ok());
  std::thread waiter([] {
    PlanSlot slot;
    const auto start = Clock::now();
    const absl::Status late =
        slot.Acquire(start + std::chrono::milliseconds(100), nullptr);
    EXPECT_TRUE(absl::IsDeadlineExceeded(late)) << late;
    EXPECT_NE(late.message().find("--planner_workers"), absl::string_view::npos);
    EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(100));
    std::atomic<int> polls{0};
    const absl::Status cancelled =
        slot.Acquire(std::nullopt, [&polls] { return ++polls > 3; });
    EXPECT_TRUE(absl::IsCancelled(cancelled)) << cancelled;
  });
  waiter.join();
}

// The planner answers a call past its deadline with its best plan so far, so a
// free slot is taken also then.
TEST(PlanSlotsTest, AFreeSlotIsTakenAlsoPastTheDeadline) {
  SetConcurrentPlans(1);
  PlanSlot slot;
  EXPECT_TRUE(slot.Acquire(Clock::now() - std::chrono::seconds(1), nullptr).ok());
}

TEST(PlanSlotsTest, AFreedSlotGoesToAWaiter) {
  SetConcurrentPlans(1);
  auto held = std::make_unique<PlanSlot>();
  ASSERT_TRUE(held->Acquire(std::nullopt, nullptr).ok());
  std::atomic<bool> got{false};
  std::thread waiter([&got] {
    PlanSlot slot;
    got = slot.Acquire(Clock::now() + std::chrono::seconds(10), nullptr).ok();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(got.load());
  held.reset();
  waiter.join();
  EXPECT_TRUE(got.load());
}

// A helper thread of a plan takes a slot only if one is free now, and never a
// second one on a thread that holds one.
TEST(PlanSlotsTest, TryAcquireTakesOnlyAFreeSlot) {
  SetConcurrentPlans(2);
  PlanSlot caller;
  ASSERT_TRUE(caller.Acquire(std::nullopt, nullptr).ok());
  PlanSlot again;
  EXPECT_FALSE(again.TryAcquire());  // this thread holds one
  std::atomic<bool> first{false}, second{true};
  std::thread helper([&] {
    PlanSlot slot;
    first = slot.TryAcquire();  // the second of two
    std::thread another([&] {
      PlanSlot none;
      second = none.TryAcquire();  // none left: no wait
    });
    another.join();
  });
  helper.join();
  EXPECT_TRUE(first.load());
  EXPECT_FALSE(second.load());
  // The helper's slot was given back.
  std::thread later([] {
    PlanSlot slot;
    EXPECT_TRUE(slot.TryAcquire());
  });
  later.join();
  SetConcurrentPlans(1);
}

// Waiters get slots in the order they came; one that gives up leaves the queue.
TEST(PlanSlotsTest, WaitersAreServedInArrivalOrder) {
  SetConcurrentPlans(1);
  auto held = std::make_unique<PlanSlot>();
  ASSERT_TRUE(held->Acquire(std::nullopt, nullptr).ok());
  std::mutex mu;
  std::vector<int> order;
  std::vector<std::thread> waiters;
  // Waiter 2 gives up before the slot comes free; the ones after it still get it.
  for (int w = 0; w < 6; ++w) {
    waiters.emplace_back([&, w] {
      PlanSlot slot;
      const auto deadline = Clock::now() + (w == 2 ? std::chrono::milliseconds(100)
                                                   : std::chrono::seconds(20));
      const absl::Status s = slot.Acquire(deadline, nullptr);
      if (w == 2) {
        EXPECT_TRUE(absl::IsDeadlineExceeded(s)) << s;
        return;
      }
      ASSERT_TRUE(s.ok()) << s;
      std::lock_guard<std::mutex> lock(mu);
      order.push_back(w);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(30));  // arrival order
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(150));  // waiter 2 has left
  held.reset();
  for (std::thread& t : waiters) t.join();
  EXPECT_EQ(order, (std::vector<int>{0, 1, 3, 4, 5}));
}

}  // namespace
}  // namespace excite::plan
