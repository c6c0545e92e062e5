// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreUninitializedVector_h
#define stmCoreUninitializedVector_h

// Arrays that the threads filling them touch first. On a virtual machine a page costs the most
// when it is first touched, as the host backs it then: on this project's 2-core machine about
// 1.6 ms per MiB from one thread and 0.9 ms from two (1,000 MiB of transparent huge pages,
// three runs each). std::vector's resize writes every element on the calling thread before a
// parallel kernel can; UninitializedVector leaves trivial elements unwritten, so that the
// kernel, which must write every element, is the first to touch them.

#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace stm
{

/// std::allocator whose construct() without arguments default-initialises (leaves a trivial
/// value unwritten) instead of value-initialising.
template <class T>
struct UninitializedAllocator : std::allocator<T>
{
  template <class U>
  struct rebind
  {
    using other = UninitializedAllocator<U>;
  };

  UninitializedAllocator() = default;
  template <class U>
  UninitializedAllocator(const UninitializedAllocator<U>&) noexcept
  {
  }

  template <class U>
  void construct(U* place) noexcept(std::is_nothrow_default_constructible<U>::value)
  {
    ::new (static_cast<void*>(place)) U;
  }
  template <class U, class... Args>
  void construct(U* place, Args&&... args)
  {
    ::new (static_cast<void*>(place)) U(std::forward<Args>(args)...);
  }
};

/// A vector whose resize() leaves trivial elements unwritten: only for arrays that a kernel
/// then writes in full before anything reads them.
template <class T>
using UninitializedVector = std::vector<T, UninitializedAllocator<T>>;

} // namespace stm

#endif
