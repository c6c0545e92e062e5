// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreExecution_h
#define stmCoreExecution_h

// The core's view of parallel execution. Algorithms are templates on an Executor type that
// provides:
//   template <class Kernel> void For(std::int64_t begin, std::int64_t end, std::int64_t grain,
//                                    Kernel& kernel);
//     calls kernel(scratch, rangeBegin, rangeEnd) over disjoint sub-ranges, where scratch is a
//     per-thread `typename Kernel::Scratch` that is reused across the ranges of one thread;
//   bool ShouldAbort();           polled by kernels, cheap, callable from any thread;
//   void ReportProgress(double);  a fraction in [0,1], ignored off the main thread.
// The VTK layer maps For onto vtkSMPTools::For with vtkSMPThreadLocal scratch; the core ships
// a sequential executor and a std::thread executor (used by the core's own tests).

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

namespace stm
{

/// Scratch type for kernels that need none.
struct NoScratch
{
};

class SequentialExecutor
{
public:
  template <class Kernel>
  void For(std::int64_t begin, std::int64_t end, std::int64_t grain, Kernel& kernel)
  {
    typename Kernel::Scratch scratch{};
    const std::int64_t step = std::max<std::int64_t>(grain, 1);
    for (std::int64_t first = begin; first < end && !this->ShouldAbort(); first += step)
    {
      kernel(scratch, first, std::min(end, first + step));
    }
  }
  bool ShouldAbort() { return this->AbortFlag.load(std::memory_order_relaxed); }
  void RequestAbort() { this->AbortFlag = true; }
  void ReportProgress(double) {}

private:
  std::atomic<bool> AbortFlag{ false };
};

/// Runs ranges on a fixed number of std::threads with dynamic range assignment; the order in
/// which ranges run differs from run to run, which is what the determinism tests need.
class ThreadPoolExecutor
{
public:
  explicit ThreadPoolExecutor(int numberOfThreads)
    : NumberOfThreads(std::max(1, numberOfThreads))
  {
  }

  template <class Kernel>
  void For(std::int64_t begin, std::int64_t end, std::int64_t grain, Kernel& kernel)
  {
    const std::int64_t step = std::max<std::int64_t>(grain, 1);
    std::atomic<std::int64_t> next{ begin };
    auto worker = [&]()
    {
      typename Kernel::Scratch scratch{};
      for (;;)
      {
        const std::int64_t first = next.fetch_add(step);
        if (first >= end || this->ShouldAbort())
        {
          return;
        }
        kernel(scratch, first, std::min(end, first + step));
      }
    };
    std::vector<std::thread> threads;
    for (int t = 1; t < this->NumberOfThreads; ++t)
    {
      threads.emplace_back(worker);
    }
    worker();
    for (auto& thread : threads)
    {
      thread.join();
    }
  }
  bool ShouldAbort() { return this->AbortFlag.load(std::memory_order_relaxed); }
  void RequestAbort() { this->AbortFlag = true; }
  void ReportProgress(double) {}

private:
  int NumberOfThreads;
  std::atomic<bool> AbortFlag{ false };
};

} // namespace stm

#endif
