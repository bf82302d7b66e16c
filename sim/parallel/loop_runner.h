// Independent iterations run by whatever schedules a solver's threads: code that only needs a
// parallel loop (the semi-implicit operator) takes a LoopRunner instead of opening threads of its
// own. Without one, the loop runs on the calling thread.
#pragma once

#include <type_traits>

namespace snowsim {

class LoopRunner {
 public:
  // body(context, first, last) for consecutive ranges covering [0, count), each range once.
  virtual void run(int count, void (*body)(void*, int, int), void* context) = 0;

 protected:
  ~LoopRunner() = default;
};

// f(i) for every i in [0, count), independent of one another.
template <class F>
void parallelFor(LoopRunner* runner, int count, F&& f) {
  if (runner == nullptr) {
    for (int i = 0; i < count; ++i) f(i);
    return;
  }
  using Body = std::remove_reference_t<F>;
  runner->run(
      count,
      [](void* context, int first, int last) {
        Body& body = *static_cast<Body*>(context);
        for (int i = first; i < last; ++i) body(i);
      },
      const_cast<void*>(static_cast<const void*>(&f)));
}

}  // namespace snowsim
