#pragma once
/// @file
/// @brief A process-wide setting for the command-line executables: freed memory kept for reuse.

namespace brainshift::core {

/// @brief Makes the C library's allocator keep freed memory for the next allocations instead of
/// returning it to the system. glibc serves each block above its mmap threshold (at most 32 MiB:
/// every volume of `register`, 16-66 MB) with a fresh mapping and unmaps it when freed, so each
/// new volume faults in zeroed pages again: ≈ 244k page faults and 0.3 s of kernel time in one
/// `register` of the 16 M-voxel Doppler, half of them avoided this way
/// (docs/history/BENCHMARKS_NOTEBOOK.md "Speed"). All threads share the one heap, and its first GiB
/// is backed by transparent huge pages (madvise), so what is still faulted in comes 2 MiB at a
/// time: on a VM whose page faults are dear that took the 16 M-voxel `register` from 2.80 to 1.90 s
/// wall (docs/history/BENCHMARKS_NOTEBOOK.md "Huge pages"). The price: the process holds its peak
/// heap until it exits, so call it only at the start of a short-lived command (`brainshift
/// register`, `replay`, `extract`, the Slicer module BrainshiftRegister), never in a library. No
/// effect (and false) without glibc.
/// @return true when the setting was applied.
bool keep_freed_memory_for_reuse();

}  // namespace brainshift::core
