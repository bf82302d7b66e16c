// An allocator for large arrays that start at zero and are mostly never touched: it takes zeroed
// memory from calloc, which the system commits page by page on first touch, and does not write
// the zeros again when the container value-initialises its elements. A grid-sized array that the
// snow only ever fills near itself then costs the memory of the part it fills.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>

namespace snowsim {

template <class T>
struct ZeroPageAllocator {
  using value_type = T;

  ZeroPageAllocator() = default;
  template <class U>
  ZeroPageAllocator(const ZeroPageAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    static_assert(alignof(T) <= alignof(std::max_align_t), "calloc cannot align T");
    void* memory = std::calloc(n, sizeof(T));
    if (memory == nullptr) throw std::bad_alloc();
    return static_cast<T*>(memory);
  }
  void deallocate(T* memory, std::size_t) noexcept { std::free(memory); }

  // Value-initialisation of a trivially zero type: calloc's memory already holds it.
  template <class U>
  void construct(U*) noexcept {
    static_assert(std::is_trivially_destructible_v<U>, "only for plain numeric element types");
  }
  template <class U, class... Args>
  void construct(U* at, Args&&... args) {
    ::new (static_cast<void*>(at)) U(std::forward<Args>(args)...);
  }

  friend bool operator==(const ZeroPageAllocator&, const ZeroPageAllocator&) { return true; }
};

}  // namespace snowsim
