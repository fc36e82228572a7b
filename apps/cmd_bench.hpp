#pragma once
/// @file
/// @brief `brainshift bench`: speed against error on the phantom cases; argument
/// parsing over run_benchmark() (apps/bench/bench.hpp, which describes the suites and outputs).

#include "apps/bench/bench.hpp"

#include <iosfwd>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The flags of `brainshift bench` (workflow/bench.hpp).
using BenchArgs = workflow::BenchOptions;
CLI::App* add_bench_command(CLI::App& app, BenchArgs& args);

/// Runs the benchmark. @return 0 when every run gave a finite answer, 2 when some run failed or
/// diverged (it is a row with its error; the others go on), 1 (by exception) on bad arguments.
int run_bench(const BenchArgs& args, std::ostream& out);

}  // namespace brainshift::apps
