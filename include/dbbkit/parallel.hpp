#pragma once
// A minimal thread pool for independent work items.

#include <atomic>
#include <thread>
#include <vector>

namespace dbbkit {

// Runs body(i) for i = 0 .. n - 1 on `threads` threads (the caller's among them),
// each taking the next index; which thread runs an index does not affect the result.
template <typename Body>
void parallel_for(long n, int threads, Body&& body) {
  std::atomic<long> next{0};
  auto worker = [&]() {
    for (long i = next++; i < n; i = next++) body(i);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

}  // namespace dbbkit
