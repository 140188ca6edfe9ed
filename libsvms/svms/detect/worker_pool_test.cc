#include "svms/detect/worker_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace svms {
namespace {

TEST(WorkerPool, RunsEveryPartOnceOnSeveralThreads) {
  WorkerPool pool(3);
  EXPECT_EQ(pool.threads(), 3);
  for (int n : {0, 1, 2, 7, 100}) {
    std::vector<std::atomic<int>> calls(n);
    std::vector<std::thread::id> by(n);
    for (int job = 0; job < 50; ++job) {
      pool.Run(n, [&](int i) {
        ++calls[i];
        by[i] = std::this_thread::get_id();
      });
    }
    for (int i = 0; i < n; ++i) EXPECT_EQ(calls[i], 50) << "n " << n << " part " << i;
  }
  // Parts that wait for each other finish only if at least two threads run them at once.
  std::atomic<int> arrived{0};
  pool.Run(2, [&](int) {
    ++arrived;
    while (arrived < 2) std::this_thread::yield();
  });
  EXPECT_EQ(arrived, 2);
}

// Run returns only once every part has returned, whether the other thread's part ends while the
// caller watches for it (within half a millisecond: 0 and 50 us) or after it has gone to sleep
// (2 ms), and what that part wrote is visible to the caller then. The two parts wait for each
// other, so each thread runs one; which one sleeps depends on who takes part 1. The caller
// watches only where the process has 2 CPUs or more (WorkerPool's spin_); elsewhere this tests
// the sleeping wait alone. The plain ints' visibility is checked in kind only under a race
// detector (ThreadSanitizer).
TEST(WorkerPool, RunReturnsAfterTheLastPartWhetherTheCallerWatchesOrSleeps) {
  WorkerPool pool(2);
  for (const int us : {0, 50, 2000}) {
    for (int job = 0; job < 20; ++job) {
      std::atomic<int> arrived{0};
      int written[2] = {0, 0};  // plain ints: Run's return is what makes them visible
      pool.Run(2, [&](int i) {
        ++arrived;
        while (arrived < 2) std::this_thread::yield();
        if (i == 1) std::this_thread::sleep_for(std::chrono::microseconds(us));
        written[i] = job + 1;
      });
      EXPECT_EQ(written[0], job + 1) << us << " us, job " << job;
      EXPECT_EQ(written[1], job + 1) << us << " us, job " << job;
    }
  }
}

// Prewake is a hint: it never keeps a worker from the next job. Woken ahead of a job, woken for
// nothing, or left to fall asleep again (2 ms idle, past its half millisecond of watching), the
// worker runs a part of the next job (its two parts wait for each other, so the job ends only
// if both threads run one), and a pool whose workers were woken for nothing stops cleanly.
TEST(WorkerPool, AWorkerWokenAheadOfAJobJoinsIt) {
  for (int round = 0; round < 20; ++round) {
    WorkerPool pool(2);
    for (int job = 0; job < 5; ++job) {
      if (job % 2 == 0) pool.Prewake();
      if (job >= 3) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      std::atomic<int> arrived{0};
      pool.Run(2, [&](int) {  // finishes only if the worker runs the other part
        ++arrived;
        while (arrived < 2) std::this_thread::yield();
      });
      EXPECT_EQ(arrived, 2);
    }
    pool.Prewake();
    pool.Prewake();
  }
  WorkerPool alone(1);
  alone.Prewake();  // no workers: nothing to wake
  int ran = 0;
  alone.Run(3, [&](int) { ++ran; });
  EXPECT_EQ(ran, 3);
}

TEST(WorkerPool, CallsFromSeveralThreadsAndFromInsideATaskAllRun) {
  WorkerPool pool(2);
  std::atomic<int> sum{0};
  auto job = [&] {
    for (int r = 0; r < 200; ++r)
      pool.Run(4, [&](int i) {
        // A nested call finds the workers busy and runs its parts on this thread.
        pool.Run(2, [&](int j) { sum += 1 + i + j; });
      });
  };
  std::thread a(job), b(job);
  job();
  a.join();
  b.join();
  // Each outer part i adds (1 + i) + (2 + i); over i = 0..3: 24; 200 jobs on each of 3 threads.
  EXPECT_EQ(sum, 3 * 200 * 24);
}

// A part that throws, on whichever thread: the exception reaches the caller of Run, the job
// ends, and the pool runs the next job normally.
TEST(WorkerPool, APartThatThrowsRethrowsOnTheCallerAndThePoolGoesOn) {
  WorkerPool pool(2);
  for (int job = 0; job < 20; ++job) {
    const int bad = job % 8;
    std::atomic<int> ran{0};
    EXPECT_THROW(pool.Run(8,
                          [&](int i) {
                            ++ran;
                            if (i == bad) throw std::runtime_error("part " + std::to_string(i));
                          }),
                 std::runtime_error);
    EXPECT_GE(ran.load(), 1);
    std::atomic<int> calls{0};
    pool.Run(8, [&](int) { ++calls; });
    EXPECT_EQ(calls.load(), 8);
  }
}

TEST(WorkerPool, OneThreadRunsOnTheCaller) {
  WorkerPool pool(1);
  EXPECT_EQ(pool.threads(), 1);
  std::vector<std::thread::id> by(5);
  pool.Run(5, [&](int i) { by[i] = std::this_thread::get_id(); });
  for (const auto& id : by) EXPECT_EQ(id, std::this_thread::get_id());
}

}  // namespace
}  // namespace svms
