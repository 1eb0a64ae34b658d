#pragma once
// A minimal thread pool for independent work items.

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace dbbkit {

// The most worker threads any operation starts, whatever it is asked for; a request
// beyond it is bad input at the command line (`--threads`, `--mc-threads`).
constexpr int kMaxThreads = 256;

// Runs body(i) for i = 0 .. n - 1 on up to `threads` threads (the caller's among
// them, never more than n), each taking the next index; which thread runs an index
// does not affect the result. When the system refuses a thread (or the memory for one) the
// work goes on on those already running. An exception thrown by body stops the handing out of new
// indices and is rethrown here once every thread has finished.
template <typename Body>
void parallel_for(long n, int threads, Body&& body) {
  std::atomic<long> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto worker = [&]() {
    for (long i = next++; i < n; i = next++) {
      try {
        body(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        next = n;
      }
    }
  };
  const long wanted =
      std::min<long>(std::max(1, std::min(threads, kMaxThreads)), std::max<long>(n, 1));
  std::vector<std::thread> pool;
  for (long t = 1; t < wanted; ++t) {
    try {
      pool.emplace_back(worker);
    } catch (...) {
      break;  // no more threads (or memory for one) to be had: the ones running share the work
    }
  }
  worker();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace dbbkit
