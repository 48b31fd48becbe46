#pragma once
// Process-wide allocator setting for programs that build large work arrays again and again
// (planning both feeds, N-buffers per view, benchmarks calling a stage in a loop).

namespace vmsim {

/// Keeps freed memory in the process instead of handing it back to the system after each
/// stage: with glibc's defaults, arrays of a few MB are mapped fresh (or the heap top trimmed)
/// on every call, and the page faults that follow cost as much as the planner's own work on
/// 10 000 points (bench_planner: velocity + acceleration 9 ms with the defaults, 4.5 ms with
/// this). Safe to call more than once; does nothing where the C library has no such setting.
void keep_freed_memory_in_process();

}  // namespace vmsim
