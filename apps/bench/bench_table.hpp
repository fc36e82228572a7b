#pragma once
/// @file
/// @brief The benchmark's outputs (bench.hpp): results.csv, results.md, the Pareto plot
/// (pareto.png through gnuplot, with its script and data), the rows as JSON and the growth fits.

#include "apps/bench/bench_run.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace brainshift::workflow {

/// Least-squares slope of log y against log x over the positive pairs; nullopt with < 2 (or a
/// degenerate x range).
std::optional<double> log_slope(const std::vector<std::pair<double, double>>& xy);

/// One row as results.json → runs[] (and, in the same key order, a line of results.csv).
nlohmann::json row_json(const BenchRow& r);

/// results.csv: a header of row_json()'s keys, a line per row (written atomically).
void write_csv(const std::filesystem::path& path, const std::vector<BenchRow>& rows);

/// `v` with `digits` decimals.
std::string fixed(double v, int digits);

/// The run's label in the tables: the method (suite cases) or sweep=value.
std::string label(const BenchRow& r);

/// results.md: the table of runs, the predicted-error table, notes and fits (`meta`: machine,
/// seed, repeat, quick, fits).
void write_markdown(const std::filesystem::path& path, const std::vector<BenchRow>& rows,
                    const nlohmann::json& meta);

/// Time against TRE for the runs on `standard` (and all cases' defaults), the Pareto front
/// (runs no other run beats in both) drawn through them, in `dir`. Returns "" or why there is no
/// plot.
std::string write_pareto(const std::filesystem::path& dir, const std::vector<BenchRow>& rows);

}  // namespace brainshift::workflow
