#pragma once
/// \file LargeArrayAllocator.hpp
/// A std::allocator for the large arrays of obs (the blocks, block numbers and column indices of
/// the stiffness and Galerkin matrices): arrays of at least 2 MB are placed on 2 MB boundaries and
/// marked for transparent huge pages (madvise MADV_HUGEPAGE; Linux's default mode "madvise" then
/// backs them by 2 MB pages). A matrix of 823,875 unknowns holds 533 MB of blocks: with 4 KB pages
/// its first touch costs 130,000 page faults and every sweep over it misses the TLB on each page;
/// measured on the step-42 run: 10 % of the whole run (docs/performance.md#threads). Smaller
/// arrays, and systems without huge pages, get ordinary memory.
///
/// New elements are default-initialised: `std::vector<int, LargeArrayAllocator<int>>(n)` and
/// resize() leave the numbers unset (Eigen's fixed-size matrices are unset anyway), so that the
/// threads that fill an array are the first to touch its pages, not one thread zeroing it before
/// (docs/performance.md#first-touch). Code that needs zeros asks for them (assign(n, 0)).
#include <sys/mman.h>

#include <cstddef>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>

namespace obs {

template <class T>
struct LargeArrayAllocator {
  using value_type = T;
  static constexpr std::size_t kHugePage = std::size_t(2) << 20;

  LargeArrayAllocator() = default;
  template <class U>
  LargeArrayAllocator(const LargeArrayAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kHugePage) return static_cast<T*>(::operator new(bytes, std::align_val_t(alignof(T))));
    const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* p = std::aligned_alloc(kHugePage, rounded);
    if (!p) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
    madvise(p, rounded, MADV_HUGEPAGE);  // a hint: ignored where huge pages are off
#endif
    return static_cast<T*>(p);
  }
  /// Default-initialisation (no value given): nothing is written for ints and Eigen's blocks.
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (n * sizeof(T) < kHugePage) ::operator delete(p, std::align_val_t(alignof(T)));
    else std::free(p);
  }
  template <class U>
  bool operator==(const LargeArrayAllocator<U>&) const noexcept {
    return true;
  }
};

}  // namespace obs
