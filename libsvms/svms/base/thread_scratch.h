// Working buffers kept per thread between calls, so that a function called every frame
// allocates nothing once its thread has warmed up (docs/flight-interface.md).
#pragma once

namespace svms {

// This thread's instance of `Buffers`, default-constructed on first use. Each type has one
// instance per thread: give every user its own struct (an anonymous-namespace struct per file),
// never a plain std::vector that another function might also ask for.
//
// Not inlined, on purpose: where a thread_local is used directly in a shared library, the
// GCC 12 build of this project was seen to look its address up again (a call to
// __tls_get_addr) across calls and blocks of the using function, inside loops too. The
// reference this returns stays in a register.
template <typename Buffers>
[[gnu::noinline]] Buffers& ThreadScratch() {
  thread_local Buffers buffers;
  return buffers;
}

}  // namespace svms
