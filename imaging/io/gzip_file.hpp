#pragma once
/// @file
/// @brief Fast gzip compression of a whole file or buffer (RFC 1952, one member), on several
/// threads: the data is cut into chunks, each deflated independently (raw deflate, the last
/// one finished, the others ended on a byte boundary by a sync flush), the streams concatenated
/// and the CRC-32s combined, so any gzip reader (zlib's gzread, Python's gzip, ITK, Slicer)
/// reads one ordinary member. The bytes written depend only on the data and the options, not
/// on thread timing. And gzip data inflated into given buffers (gunzip_into()), for readers that
/// place the bytes themselves (nifti_voxels.hpp).

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// How gzip_buffer() / gzip_file() compress.
struct GzipOptions {
  /// zlib level 0 (stored) … 9. Default 1 with the run-length strategy: on float volumes it
  /// compresses as well as gzip's default level 6 in a third of the time
  /// (docs/history/BENCHMARKS_NOTEBOOK.md).
  int level = 1;
  bool run_length = true;  ///< Z_RLE strategy (otherwise Z_DEFAULT_STRATEGY)
  int threads = 2;         ///< chunks compressed in parallel (≥ 1); more only above 1 MiB each
  /// Levels ≥ 1 by ISA-L's igzip (at min(level, 3), run_length ignored) when built with it
  /// (gzip_has_fast_deflate()): about 4x less CPU than zlib on the float volumes of `register`,
  /// files about 1.5 % larger (docs/history/BENCHMARKS_NOTEBOOK.md "Speed"). The decompressed bytes
  /// are the same.
  bool fast = true;
};

/// True when this build has ISA-L's igzip for GzipOptions::fast (found by cmake/deps/isal.cmake).
bool gzip_has_fast_deflate();

/// Compresses `size` bytes at `data` into a gzip file at `target` (written directly: wrap the
/// call in write_atomically() for an atomic file).
/// \throws brainshift::Error (one line naming `target`) on bad options or a failed write.
void gzip_buffer(const void* data, std::size_t size, const std::filesystem::path& target,
                 const GzipOptions& options = {});

/// The input is deflated in blocks of this many bytes; chunks (one per thread) are whole blocks.
inline constexpr std::size_t kGzipBlockBytes = std::size_t(1) << 20;

/// Writes the input's bytes [offset, offset + n) to `out`. gzip_source() asks for each block once,
/// in order within a chunk, with `offset` a multiple of kGzipBlockBytes and n ≤ kGzipBlockBytes,
/// possibly from several threads at once (one per chunk).
using ByteSource = std::function<void(std::size_t offset, std::size_t n, unsigned char* out)>;

/// gzip_buffer() of `size` bytes made block by block by `source`: what a writer uses whose file
/// bytes are not in memory as one buffer (a reordered or converted volume), so that no copy of the
/// whole file is made. The same bytes as gzip_buffer() of the same input and options.
/// \throws brainshift::Error as gzip_buffer().
void gzip_source(std::size_t size, const ByteSource& source, const std::filesystem::path& target,
                 const GzipOptions& options = {});

/// Compresses the file `source` into the gzip file `target` (see gzip_buffer()).
/// \throws brainshift::Error naming the file that cannot be read or written.
void gzip_file(const std::filesystem::path& source, const std::filesystem::path& target,
               const GzipOptions& options = {});

/// One output of gunzip_into(): `size` bytes at `data`.
struct GunzipPart {
  unsigned char* data;
  std::size_t size;
};

/// Inflates the gzip data `in` (one member or several, as concatenated gzip files) into the
/// consecutive outputs `parts`, each filled completely in order, and stops when the last is full
/// (what follows is not read, nor the CRC checked). By ISA-L's igzip where the build has it
/// (gzip_has_fast_deflate()), else by zlib; the same bytes either way.
/// \throws brainshift::Error naming `file` when the data is not gzip or ends before the parts
/// are full (truncated).
void gunzip_into(const std::vector<unsigned char>& in, const std::vector<GunzipPart>& parts,
                 const std::string& file);

}  // namespace brainshift::imaging
