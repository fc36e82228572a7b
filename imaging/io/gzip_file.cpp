#include "imaging/io/gzip_file.hpp"

#include "core/error.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <limits>
#include <vector>
#include <zlib.h>

#ifdef BS_HAVE_ISAL
#include <isa-l/igzip_lib.h>
#endif

namespace brainshift::imaging {
namespace {

/// One chunk deflated as raw deflate (no header), ended by Z_SYNC_FLUSH or, for the last chunk,
/// Z_FINISH; its CRC-32 alongside.
struct Chunk {
  std::vector<unsigned char> out;
  uLong crc = 0;
  std::string error;
};

#ifdef BS_HAVE_ISAL
/// deflate_chunk() by ISA-L's igzip at level min(level, 3) (its highest; run_length has no
/// counterpart there): the same raw-deflate chunk contract, other (equally valid) bytes.
void isal_deflate_chunk(const unsigned char* in, std::size_t n, bool last, const GzipOptions& o,
                        Chunk& c) {
  const int level = std::min(o.level, 3);
  std::vector<unsigned char> level_buffer(level == 1   ? ISAL_DEF_LVL1_DEFAULT
                                          : level == 2 ? ISAL_DEF_LVL2_DEFAULT
                                                       : ISAL_DEF_LVL3_DEFAULT);
  isal_zstream z;
  isal_deflate_init(&z);
  z.level = static_cast<std::uint32_t>(level);
  z.level_buf = level_buffer.data();
  z.level_buf_size = static_cast<std::uint32_t>(level_buffer.size());
  z.gzip_flag = IGZIP_DEFLATE;
  z.end_of_stream = last ? 1 : 0;
  z.flush = last ? NO_FLUSH : SYNC_FLUSH;      // a chunk before the last ends on a byte boundary
  z.next_in = const_cast<unsigned char*>(in);  // ISA-L's API is not const-correct
  z.avail_in = static_cast<std::uint32_t>(n);
  // igzip has no bound function: start at the input size plus 1/8 and grow while it fills the
  // output (its documented calling pattern: call again while avail_out comes back 0).
  c.out.resize(n + n / 8 + 65536);
  std::size_t done = 0;
  for (;;) {
    z.next_out = c.out.data() + done;
    z.avail_out = static_cast<std::uint32_t>(c.out.size() - done);
    if (isal_deflate(&z) != COMP_OK) {
      c.error = "isal_deflate failed";
      return;
    }
    done = c.out.size() - z.avail_out;
    if (z.avail_out != 0) break;
    c.out.resize(c.out.size() + c.out.size() / 2);
  }
  if (z.avail_in != 0 || (last && z.internal_state.state != ZSTATE_END))
    c.error = "isal_deflate did not finish";
  c.out.resize(done);
}
#endif

void deflate_chunk(const unsigned char* in, std::size_t n, bool last, const GzipOptions& o,
                   Chunk& c) {
  c.crc = crc32_z(crc32_z(0L, Z_NULL, 0), in, n);
#ifdef BS_HAVE_ISAL
  if (o.fast && o.level > 0) {
    isal_deflate_chunk(in, n, last, o, c);
    return;
  }
#endif
  z_stream z{};
  if (deflateInit2(&z, o.level, Z_DEFLATED, -15, 8, o.run_length ? Z_RLE : Z_DEFAULT_STRATEGY) !=
      Z_OK) {
    c.error = "deflateInit2 failed";
    return;
  }
  c.out.resize(deflateBound(&z, uLong(n)) + 64);
  z.next_in = const_cast<unsigned char*>(in);  // zlib's API is not const-correct
  z.avail_in = uInt(n);
  z.next_out = c.out.data();
  z.avail_out = uInt(c.out.size());
  const int rc = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
  if ((last && rc != Z_STREAM_END) || (!last && rc != Z_OK) || z.avail_in != 0)
    c.error = "deflate failed";
  c.out.resize(c.out.size() - z.avail_out);
  deflateEnd(&z);
}

void put_le32(std::ofstream& f, std::uint32_t v) {
  const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                              static_cast<unsigned char>(v >> 16),
                              static_cast<unsigned char>(v >> 24)};
  f.write(reinterpret_cast<const char*>(b), 4);
}

}  // namespace

bool gzip_has_fast_deflate() {
#ifdef BS_HAVE_ISAL
  return true;
#else
  return false;
#endif
}

void gzip_buffer(const void* data, std::size_t size, const std::filesystem::path& target,
                 const GzipOptions& options) {
  BS_VERIFY(options.level >= 0 && options.level <= 9 && options.threads >= 1,
            target.string() << ": gzip level must be 0-9 and threads >= 1, got " << options.level
                            << " and " << options.threads);
  // Chunks of at least 1 MiB, each below zlib's 32-bit avail_in.
  constexpr std::size_t min_chunk = std::size_t(1) << 20, max_chunk = std::size_t(1) << 30;
  std::size_t chunks =
      std::max<std::size_t>(1, std::min<std::size_t>(options.threads, size / min_chunk));
  chunks = std::max(chunks, (size + max_chunk - 1) / max_chunk);
  const auto* in = static_cast<const unsigned char*>(data);
  std::vector<Chunk> out(chunks);
  auto run = [&](std::size_t c) {
    const std::size_t b = size * c / chunks, e = size * (c + 1) / chunks;
    deflate_chunk(in + b, e - b, c + 1 == chunks, options, out[c]);
  };
  core::parallel_chunks(chunks, static_cast<int>(chunks), run);
  uLong crc = out[0].crc;
  for (std::size_t c = 0; c < chunks; ++c) {
    BS_VERIFY(out[c].error.empty(), target.string() << ": cannot compress: " << out[c].error);
    if (c > 0)
      crc = crc32_combine(crc, out[c].crc, z_off_t(size * (c + 1) / chunks - size * c / chunks));
  }
  std::ofstream f(target, std::ios::binary | std::ios::trunc);
  BS_VERIFY(f.good(), target.string() << ": cannot open for writing");
  // gzip header: magic, deflate, no flags, no mtime, no extra flags, OS unknown (reproducible).
  const unsigned char header[10] = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 255};
  f.write(reinterpret_cast<const char*>(header), sizeof header);
  for (const Chunk& c : out)
    f.write(reinterpret_cast<const char*>(c.out.data()), std::streamsize(c.out.size()));
  put_le32(f, std::uint32_t(crc));
  put_le32(f, std::uint32_t(size & 0xffffffffU));
  f.flush();
  BS_VERIFY(f.good(), target.string() << ": cannot write (disk full?)");
}

void gzip_file(const std::filesystem::path& source, const std::filesystem::path& target,
               const GzipOptions& options) {
  std::ifstream f(source, std::ios::binary | std::ios::ate);
  BS_VERIFY(f.good(), source.string() << ": cannot open for reading");
  const std::streamsize n = f.tellg();
  BS_VERIFY(n >= 0, source.string() << ": cannot read its size");
  std::vector<char> data(static_cast<std::size_t>(n));
  f.seekg(0);
  BS_VERIFY(n == 0 || f.read(data.data(), n), source.string() << ": cannot read");
  gzip_buffer(data.data(), data.size(), target, options);
}

}  // namespace brainshift::imaging
