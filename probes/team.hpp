// A fixed team of threads that run one function together, started and stopped at barriers,
// so that the time of one parallel repetition is measured from the moment every thread is
// released to the moment the last one finishes (thread creation stays out of the timing).
#pragma once

#include <atomic>
#include <barrier>
#include <cstdint>
#include <functional>
#include <thread>
#include <vector>

namespace dtflop::probes {

class Team {
 public:
  // `threads` >= 1 workers; the calling thread is worker 0, so threads - 1 are started.
  explicit Team(int threads);
  ~Team();
  Team(const Team&) = delete;
  Team& operator=(const Team&) = delete;

  int size() const { return size_; }

  // Runs fn(worker) on every worker at once; returns the wall time in seconds from the
  // common start to the end of the slowest worker. An exception thrown by a worker is
  // re-thrown here (the first one).
  double run(const std::function<void(int worker)>& fn);

  // Runs fn(worker, chunk) for chunks 0 .. chunks - 1, each worker taking the next chunk as it
  // finishes one (as OpenMP's dynamic schedule does, which the CPU backends use): a worker that
  // loses its CPU to another process does fewer chunks instead of holding up the end, so the time
  // is the team's throughput, as a backend sees it. Returns the wall time as run() does.
  double run_chunks(std::int64_t chunks, const std::function<void(int worker, std::int64_t chunk)>& fn);

 private:
  void worker_loop(int index);
  int size_;
  std::barrier<> start_;
  std::barrier<> done_;
  const std::function<void(int)>* job_ = nullptr;
  bool quit_ = false;
  std::vector<std::exception_ptr> errors_;
  std::vector<std::jthread> threads_;
  std::atomic<std::int64_t> next_chunk_{0};
};

// CPUs this process may run on (the affinity mask; hardware_concurrency as fallback).
int usable_cpus();

}  // namespace dtflop::probes
