#include "svms/detect/worker_pool.h"

#include <algorithm>
#include <chrono>
#if defined(__linux__)
#include <sched.h>
#endif

namespace svms {

namespace {

// How long an idle thread watches for what it waits for (a worker for the next job, the caller
// for the workers' last parts) before it sleeps, when the pool has a CPU for each thread.
constexpr auto kWatch = std::chrono::microseconds(500);

// The CPUs this process may run on (its affinity mask; the hardware's count elsewhere).
int UsableCpus() {
#if defined(__linux__)
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof(set), &set) == 0) return CPU_COUNT(&set);
#endif
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace

WorkerPool::WorkerPool(int threads) {
  const int workers = std::max(threads, 1) - 1;
  spin_ = workers > 0 && UsableCpus() >= workers + 1;
  workers_.reserve(workers);
  try {
    for (int k = 0; k < workers; ++k) workers_.emplace_back([this] { WorkerLoop(); });
  } catch (...) {
    // A thread that could not start (the system's thread limit): stop and join the ones that
    // did, so that the exception reaches the caller instead of std::terminate (a joinable
    // std::thread destroyed).
    Stop();
    throw;
  }
}

WorkerPool::~WorkerPool() { Stop(); }

void WorkerPool::Stop() {
  stopping_.store(true);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::Work() {
  for (int i; (i = next_.fetch_add(1, std::memory_order_relaxed)) < n_;) {
    try {
      call_(task_, i);
    } catch (...) {
      // Kept for the caller; no further parts are handed out.
      std::lock_guard<std::mutex> lock(mutex_);
      if (!error_) error_ = std::current_exception();
      next_.store(n_, std::memory_order_relaxed);
    }
  }
}

void WorkerPool::Dispatch(int n, Call call, const void* task) {
  bool expected = false;
  if (workers_.empty() || n <= 1 || !busy_.compare_exchange_strong(expected, true)) {
    for (int i = 0; i < n; ++i) call(task, i);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    call_ = call;
    task_ = task;
    n_ = n;
    next_.store(0, std::memory_order_relaxed);
    error_ = nullptr;
    open_ = true;
    ++generation_;
    announced_.store(generation_, std::memory_order_release);
  }
  wake_.notify_all();
  Work();
  // Every part has been handed out. Workers that have not joined yet stay out (they would see
  // the next job's counter with this job's task); the ones inside finish their parts.
  {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = false;
  }
  // A worker's last part usually ends within a fraction of a millisecond of the caller's. With
  // a CPU for each thread the caller watches for that instead of sleeping at once: asleep, it
  // would wait for the kernel to wake it (a futex wake-up; on a virtual machine, an
  // interrupt to a halted virtual CPU), and the frame waits with it.
  // Unlike the workers' watch it does not yield: what it waits for is running on the other
  // CPUs, the watch is bounded by kWatch, and a yield every 64 checks (a system call) took back
  // all it gained on a 2-CPU virtual machine (the commit's message has the figures).
  if (spin_ && inside_.load(std::memory_order_acquire) != 0) {
    const auto spin_end = std::chrono::steady_clock::now() + kWatch;
    for (int k = 0; inside_.load(std::memory_order_acquire) != 0; ++k) {
      if (k % 64 == 63 && std::chrono::steady_clock::now() >= spin_end) break;
      CpuRelax();
    }
  }
  std::exception_ptr error;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return inside_.load(std::memory_order_acquire) == 0; });
    std::swap(error, error_);
  }
  busy_.store(false);
  if (error) std::rethrow_exception(error);
}

void WorkerPool::Prewake() {
  if (workers_.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++prewakes_;
  }
  wake_.notify_all();
}

void WorkerPool::WorkerLoop() {
  uint64_t seen = 0, prewakes_seen = 0;
  for (;;) {
    // Between the jobs of one frame (the edge map's two passes, the chains, the quads) the
    // caller works alone for tenths of a millisecond; a worker asleep on the condition variable
    // takes about as long to wake (a futex wake-up, more on a virtual machine), and a job that
    // is handed out before it arrives is done by the caller alone. So, with a CPU for each
    // thread (spin_), an idle worker first watches for the next job for kWatch, then sleeps,
    // yielding its CPU every 64 checks to any other thread that is ready to run there. It costs
    // the second core up to kWatch of watching after a frame's last job.
    const auto spin_end = std::chrono::steady_clock::now() + kWatch;
    for (int k = 0; spin_ && announced_.load(std::memory_order_acquire) == seen &&
                    !stopping_.load(std::memory_order_relaxed);
         ++k) {
      if (k % 64 == 63) {
        if (std::chrono::steady_clock::now() >= spin_end) break;
        std::this_thread::yield();
      }
      CpuRelax();
    }
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] {
        return stop_ || (open_ && generation_ != seen) || prewakes_ != prewakes_seen;
      });
      if (stop_) return;
      if (!(open_ && generation_ != seen)) {
        // Woken ahead of a job (Prewake), or the job it saw announced while watching has been
        // handed out already: watch for the next one.
        prewakes_seen = prewakes_;
        seen = generation_;
        continue;
      }
      prewakes_seen = prewakes_;
      seen = generation_;
      inside_.fetch_add(1, std::memory_order_relaxed);
    }
    Work();
    // The last worker out wakes the caller if it sleeps: under the mutex, so that the caller
    // cannot miss it between testing inside_ and going to sleep.
    if (inside_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      std::lock_guard<std::mutex> lock(mutex_);
      done_.notify_one();
    }
  }
}

}  // namespace svms
