// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSMPExecutor
 * @brief   runs the core's range kernels with vtkSMPTools (private to the module)
 *
 * The core algorithms are templates on an executor (see Filters/Core/Common/Execution.h). This
 * one maps For() onto vtkSMPTools::For with one vtkSMPThreadLocal scratch per thread and
 * reports progress, mapped into [ProgressBegin, ProgressEnd], from the thread that runs
 * RequestData only: ParaView's progress handler, which is also where the GUI's abort arrives,
 * is not thread-safe.
 *
 * VTK 9.2's STDThread backend never runs a chunk on the thread that calls vtkSMPTools::For: it
 * waits for a pool of its own. So that progress and abort keep flowing inside parallel loops,
 * For() then runs vtkSMPTools::For on a helper thread while the calling thread relays the
 * latest progress the kernels reported, and polls the abort, every RelayInterval. On the
 * Sequential backend the kernels run on the calling thread and report directly.
 */

#ifndef stmSMPExecutor_h
#define stmSMPExecutor_h

#include "vtkAlgorithm.h"
#include "vtkCommand.h"
#include "vtkSMPThreadLocal.h"
#include "vtkSMPTools.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <exception>
#include <mutex>
#include <thread>

class stmSMPExecutor
{
public:
  explicit stmSMPExecutor(vtkAlgorithm* algorithm)
    : Algorithm(algorithm)
    , MainThread(std::this_thread::get_id())
  {
  }

  /// Progress reported by kernels in [0,1] lands in [begin, end] of the filter's progress.
  void SetProgressRange(double begin, double end)
  {
    this->ProgressBegin = begin;
    this->ProgressEnd = end;
    this->RelayedFraction = 0.0;
  }

  template <class Kernel>
  void For(std::int64_t begin, std::int64_t end, std::int64_t grain, Kernel& kernel)
  {
    if (begin >= end)
    {
      return;
    }
    Adapter<Kernel> adapter{ &kernel, {} };
    auto runLoop = [&]()
    {
      vtkSMPTools::For(static_cast<vtkIdType>(begin), static_cast<vtkIdType>(end),
        static_cast<vtkIdType>(grain), adapter);
    };
    if (this->NeedsRelay(end - begin, grain))
    {
      this->RunWhileRelaying(runLoop);
    }
    else
    {
      runLoop();
    }
  }

  /// The work reported so far (a fraction of the current range) is done: later progress in
  /// [0,1] lands in what is left of the range, so that it never goes back.
  void StartRemainingProgressAt(double fraction)
  {
    this->ProgressBegin += (this->ProgressEnd - this->ProgressBegin) * fraction;
    this->RelayedFraction = 0.0;
  }

  bool ShouldAbort()
  {
    if (this->Aborted.load(std::memory_order_relaxed))
    {
      return true;
    }
    // While relaying, the calling thread polls the abort; the pool's threads only read the flag.
    const bool designated = !this->Relaying.load(std::memory_order_relaxed) &&
      (vtkSMPTools::IsParallelScope() ? vtkSMPTools::GetSingleThread() : this->IsMainThread());
    if (designated && this->Algorithm->CheckAbort())
    {
      this->Aborted = true;
    }
    return this->Aborted.load(std::memory_order_relaxed);
  }

  void ReportProgress(double fraction)
  {
    if (this->IsMainThread())
    {
      this->UpdateProgressFromMainThread(fraction);
      return;
    }
    // Threads finish chunks out of order: keep the largest fraction, so progress never goes back.
    double seen = this->RelayedFraction.load(std::memory_order_relaxed);
    while (fraction > seen &&
      !this->RelayedFraction.compare_exchange_weak(seen, fraction, std::memory_order_relaxed))
    {
    }
  }

private:
  /// How often the calling thread relays progress and polls the abort during a parallel loop.
  static constexpr std::chrono::milliseconds RelayInterval{ 50 };

  template <class Kernel>
  struct Adapter
  {
    Kernel* Work;
    vtkSMPThreadLocal<typename Kernel::Scratch> Scratch;
    void operator()(vtkIdType begin, vtkIdType end)
    {
      (*this->Work)(this->Scratch.Local(), begin, end);
    }
  };

  bool IsMainThread() const { return std::this_thread::get_id() == this->MainThread; }

  /// True when the loop would run off the calling thread and somebody listens to progress (the
  /// GUI's abort arrives at progress events). A helper thread costs tens of microseconds, and
  /// MultiMaterialCut alone runs thousands of loops: stmesh, which does not listen, pays nothing.
  bool NeedsRelay(std::int64_t size, std::int64_t grain) const
  {
    // VTK 9.2's STDThread runs a loop of one grain inline, and every other one on its pool,
    // also with one thread.
    const bool pooled = grain <= 0 ? size > 1 : grain < size;
    const char* backend = vtkSMPTools::GetBackend();
    return pooled && this->IsMainThread() && !vtkSMPTools::IsParallelScope() && backend &&
      std::strcmp(backend, "STDThread") == 0 &&
      this->Algorithm->HasObserver(vtkCommand::ProgressEvent);
  }

  void UpdateProgressFromMainThread(double fraction)
  {
    this->RelayedFraction.store(fraction, std::memory_order_relaxed);
    this->Algorithm->UpdateProgress(
      this->ProgressBegin + (this->ProgressEnd - this->ProgressBegin) * fraction);
  }

  template <class Loop>
  void RunWhileRelaying(Loop& runLoop)
  {
    std::mutex mutex;
    std::condition_variable finishedSignal;
    bool finished = false;
    std::exception_ptr failure;
    this->Relaying = true;
    std::thread helper(
      [&]()
      {
        try
        {
          runLoop();
        }
        catch (...)
        {
          failure = std::current_exception();
        }
        std::lock_guard<std::mutex> lock(mutex);
        finished = true;
        finishedSignal.notify_one();
      });
    double relayed = this->RelayedFraction.load(std::memory_order_relaxed);
    std::unique_lock<std::mutex> lock(mutex);
    while (!finishedSignal.wait_for(lock, RelayInterval, [&] { return finished; }))
    {
      lock.unlock();
      const double latest = this->RelayedFraction.load(std::memory_order_relaxed);
      if (latest > relayed)
      {
        relayed = latest;
        this->UpdateProgressFromMainThread(latest);
      }
      if (!this->Aborted.load(std::memory_order_relaxed) && this->Algorithm->CheckAbort())
      {
        this->Aborted = true;
      }
      lock.lock();
    }
    lock.unlock();
    helper.join();
    this->Relaying = false;
    if (failure)
    {
      std::rethrow_exception(failure);
    }
  }

  vtkAlgorithm* Algorithm;
  std::thread::id MainThread;
  std::atomic<bool> Aborted{ false };
  std::atomic<bool> Relaying{ false };
  std::atomic<double> RelayedFraction{ 0.0 };
  double ProgressBegin = 0.0;
  double ProgressEnd = 1.0;
};

#endif
