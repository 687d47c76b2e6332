#include "probes/team.hpp"

#include <chrono>
#include <stdexcept>

#if defined(__linux__)
#include <sched.h>
#endif

namespace dtflop::probes {

int usable_cpus() {
#if defined(__linux__)
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return n;
  }
#endif
  const unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? static_cast<int>(n) : 1;
}

Team::Team(int threads)
    : size_(threads),
      start_(threads >= 1 ? threads : 1),
      done_(threads >= 1 ? threads : 1),
      errors_(static_cast<std::size_t>(threads >= 1 ? threads : 1)) {
  if (threads < 1) throw std::invalid_argument("a thread team needs at least one thread");
  threads_.reserve(static_cast<std::size_t>(threads - 1));
  for (int i = 1; i < threads; ++i) threads_.emplace_back([this, i] { worker_loop(i); });
}

Team::~Team() {
  quit_ = true;
  start_.arrive_and_wait();  // releases the workers, which see quit_ and leave
}

void Team::worker_loop(int index) {
  for (;;) {
    start_.arrive_and_wait();
    if (quit_) return;
    try {
      (*job_)(index);
    } catch (...) {
      errors_[static_cast<std::size_t>(index)] = std::current_exception();
    }
    done_.arrive_and_wait();
  }
}

double Team::run(const std::function<void(int)>& fn) {
  job_ = &fn;
  for (auto& e : errors_) e = nullptr;
  // The clock starts before the caller releases the workers (they wait at the barrier already):
  // a caller that lost its CPU right after the release would otherwise start it late, after
  // the others had done the work (with run_chunks(), all of it).
  const auto t0 = std::chrono::steady_clock::now();
  start_.arrive_and_wait();
  try {
    fn(0);
  } catch (...) {
    errors_[0] = std::current_exception();
  }
  done_.arrive_and_wait();
  const auto t1 = std::chrono::steady_clock::now();
  job_ = nullptr;
  for (auto& e : errors_)
    if (e) std::rethrow_exception(e);
  return std::chrono::duration<double>(t1 - t0).count();
}

double Team::run_chunks(std::int64_t chunks, const std::function<void(int, std::int64_t)>& fn) {
  next_chunk_.store(0, std::memory_order_relaxed);
  return run([&](int w) {
    for (std::int64_t c = next_chunk_.fetch_add(1, std::memory_order_relaxed); c < chunks;
         c = next_chunk_.fetch_add(1, std::memory_order_relaxed))
      fn(w, c);
  });
}

}  // namespace dtflop::probes
