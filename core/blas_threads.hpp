#pragma once
/// @file
/// @brief Which BLAS serves the process, and its thread count (OpenBLAS; see
/// cmake/deps/blas.cmake).

#include <string>

namespace brainshift::core {

/// @brief The shared library that defines the process's `dgemm_` (the BLAS CHOLMOD's supernodal
/// factorisation and solves call), e.g. ".../libopenblas.so.0"; empty when it cannot be told.
[[nodiscard]] std::string blas_library();

/// @brief OpenBLAS's thread count; 0 when the build does not link OpenBLAS.
[[nodiscard]] int blas_threads();

/// @brief One BLAS thread for the intra-operative commands, unless the user set
/// OPENBLAS_NUM_THREADS. They run their own two threads (the model loads while the Doppler is
/// extracted; the outputs are written on two threads) on models of 1-2k nodes, whose BLAS calls
/// are too small to share: a second OpenBLAS thread only spins against ours (measured on the
/// 2-core VM: `register` 0.1-0.2 s slower with two; docs/BENCHMARKS.md "BLAS under CHOLMOD,
/// idle"). Call it at the start of a command, never in a library.
/// @return true when the setting was applied (OpenBLAS linked and the variable not set).
bool one_blas_thread_unless_set();

}  // namespace brainshift::core
