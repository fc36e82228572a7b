#pragma once
/// @file
/// @brief The compliance cache file written by `brainshift prepare` (MODEL/compliance.bin) and
/// adopted by `register` / `replay`: the dense block C = K0_ff⁻¹ on the DOFs of the nodes the
/// vessel skeleton and collision surface map to (constraints/solver/compliance_operator.hpp),
/// with the stiffness fingerprint of the model it belongs to.
///
/// Layout (little-endian): 8-byte magic "BSCOMPL\0", uint32 version (1), uint32 0,
/// uint64 fingerprint, int64 node count |S|, |S| int64 node indices, the lower triangle of the
/// (3|S|)² symmetric matrix column by column as float64, then a uint64 FNV-1a of everything
/// before it (detects truncation and corruption). Units: mm/mN.
///
/// The file is a cache, not a source of truth: the compliance operator checks the fingerprint,
/// the nodes and two columns against fresh solves before using it.

#include "constraints/solver/compliance_operator.hpp"

#include <filesystem>

namespace brainshift::workflow {

inline constexpr int compliance_cache_version = 1;

/// Writes `block` to `path` atomically (temporary name, then rename).
/// \throws brainshift::Error naming `path` when the block is not square 3|nodes| or the file
/// cannot be written.
void write_compliance_cache(const std::filesystem::path& path,
                            const constraints::ComplianceBlock& block);

/// Reads a compliance cache.
/// \throws brainshift::Error, one line naming `path`: cannot read, not a compliance cache,
/// another version, truncated or corrupted (checksum).
constraints::ComplianceBlock read_compliance_cache(const std::filesystem::path& path);

}  // namespace brainshift::workflow
