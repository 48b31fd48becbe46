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

/// Hands the memory freed so far back to the system (glibc: malloc_trim). For a long job after
/// a stage that freed much more than the stages after it will reuse (the reference run's
/// traces): kept, it would add to every later stage's peak. Does nothing elsewhere.
void return_freed_memory_to_system();

}  // namespace vmsim
