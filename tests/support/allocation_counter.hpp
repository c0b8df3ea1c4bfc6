// Counts operator new. A test binary that links allocation_counter_dep has
// every global operator new replaced by a counting one; counting is switched
// on per thread, so a test can watch exactly the thread that must not
// allocate (the real-time simulation thread) while others go on as usual.
#pragma once

namespace sculpt::support {

// Count (or stop counting) the allocations made by the calling thread.
void count_allocations_on_this_thread(bool on);
// Allocations counted since the last reset, on every counting thread.
long counted_allocations();
void reset_counted_allocations();

}  // namespace sculpt::support
