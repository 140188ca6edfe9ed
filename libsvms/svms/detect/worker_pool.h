// A small fixed set of threads that share the parts of one job with the thread that asks.
//
// The detector splits one frame into parts (bands of rows of the edge map, chunks of edge
// chains, candidate quads) whose results go to slots of their own and are put together in a
// fixed order afterwards: which thread ran which part never shows in a result. A part may wait
// for an earlier one (the chains' fits for the linking, a quad's pose for its corners): parts
// are handed out in order, so the one waited for has always been started.
// The pool only hands the parts out. Its threads live as long as the pool, so whatever they
// keep per thread (the detector's thread_local scratch buffers) is grown once and reused, and
// a job allocates nothing on the heap. An idle worker watches for the next job for half a
// millisecond before it sleeps (WorkerLoop), so that the short jobs of one frame, a few tenths
// of a millisecond apart, find it awake; a caller whose parts are done watches as long for the
// workers' last ones (Dispatch). Both only with a CPU for each thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace svms {

// One step of a busy wait: the CPU's spin-wait hint (x86 pause, ARM yield), so that a waiting
// thread leaves the core's resources to its sibling and draws less power.
inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
  __asm__ __volatile__("yield");
#endif
}

class WorkerPool {
 public:
  // `threads` (>= 1) threads work on each job: the caller of Run and threads - 1 workers
  // started here (none for 1).
  explicit WorkerPool(int threads);
  ~WorkerPool();  // waits for the workers to finish their current part and stops them
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }

  // Calls task(i) once for every i in [0, n), each on one of the pool's threads (the caller's
  // among them), and returns when every call has returned. Parts are handed out in the order
  // of i as threads become free. May be called from several threads at once: a call that
  // finds the workers busy with another job runs all its parts on its own thread (so does a
  // call from inside a task). A part that throws ends the job as one thread would: no further
  // parts are started, the running ones finish, and the first exception is rethrown here, on
  // the caller's thread (never on a worker's, where it would end the program). No heap
  // allocation unless a part throws.
  template <typename Task>
  void Run(int n, const Task& task) {
    Dispatch(
        n, [](const void* t, int i) { (*static_cast<const Task*>(t))(i); }, &task);
  }

  // Wakes the workers without a job: they watch for one for half a millisecond (WorkerLoop),
  // when the pool has a CPU for each of its threads. Called where a job is soon to come (the
  // start of a frame), it hides their wake-up behind the caller's own work instead of the
  // first job's. Only a hint: no job waits for it.
  void Prewake();

 private:
  using Call = void (*)(const void* task, int i);
  void Dispatch(int n, Call call, const void* task);
  void Stop();  // stops the workers and joins them
  void Work();
  void WorkerLoop();

  // Whether idle workers watch for the next job before sleeping: only when this process may
  // run on at least threads() CPUs, so that a watching worker never takes the caller's CPU.
  bool spin_ = false;
  std::atomic<bool> busy_{false};  // a job is using the workers
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  // The current job, set under mutex_ by its caller while no worker is inside a job.
  Call call_ = nullptr;
  const void* task_ = nullptr;
  int n_ = 0;
  std::atomic<int> next_{0};  // the next part to hand out
  uint64_t generation_ = 0;   // counts jobs: a worker joins each job once
  // generation_, readable without the mutex: what an idle worker spins on (WorkerLoop).
  std::atomic<uint64_t> announced_{0};
  bool open_ = false;      // workers may still join the current job
  uint64_t prewakes_ = 0;  // counts Prewake calls: a sleeping worker wakes for each
  // Workers inside the current job: incremented under mutex_ while open_, decremented without
  // it; the worker that brings it to 0 notifies done_ under mutex_ (Dispatch watches it, then
  // waits on done_).
  std::atomic<int> inside_{0};
  bool stop_ = false;
  std::exception_ptr error_;  // the current job's first exception, under mutex_
  std::vector<std::thread> workers_;
};

}  // namespace svms
