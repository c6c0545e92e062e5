// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSMPExecutor
 * @brief   runs the core's range kernels with vtkSMPTools (private to the module)
 *
 * The core algorithms are templates on an executor (see Filters/Core/Common/Execution.h). This
 * one maps For() onto vtkSMPTools::For with one vtkSMPThreadLocal scratch per thread, checks
 * the algorithm's abort flag from the single designated thread only, and reports progress from
 * the thread that runs RequestData, mapped into [ProgressBegin, ProgressEnd].
 */

#ifndef stmSMPExecutor_h
#define stmSMPExecutor_h

#include "vtkAlgorithm.h"
#include "vtkSMPThreadLocal.h"
#include "vtkSMPTools.h"

#include <atomic>
#include <cstdint>
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
  }

  template <class Kernel>
  void For(std::int64_t begin, std::int64_t end, std::int64_t grain, Kernel& kernel)
  {
    if (begin >= end)
    {
      return;
    }
    Adapter<Kernel> adapter{ &kernel, {} };
    vtkSMPTools::For(static_cast<vtkIdType>(begin), static_cast<vtkIdType>(end),
      static_cast<vtkIdType>(grain), adapter);
  }

  /// The work reported so far (a fraction of the current range) is done: later progress in
  /// [0,1] lands in what is left of the range, so that it never goes back.
  void StartRemainingProgressAt(double fraction)
  {
    this->ProgressBegin += (this->ProgressEnd - this->ProgressBegin) * fraction;
  }

  bool ShouldAbort()
  {
    if (this->Aborted.load(std::memory_order_relaxed))
    {
      return true;
    }
    const bool designated =
      vtkSMPTools::IsParallelScope() ? vtkSMPTools::GetSingleThread() : this->IsMainThread();
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
      this->Algorithm->UpdateProgress(
        this->ProgressBegin + (this->ProgressEnd - this->ProgressBegin) * fraction);
    }
  }

private:
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

  vtkAlgorithm* Algorithm;
  std::thread::id MainThread;
  std::atomic<bool> Aborted{ false };
  double ProgressBegin = 0.0;
  double ProgressEnd = 1.0;
};

#endif
