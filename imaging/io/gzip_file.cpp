#include "imaging/io/gzip_file.hpp"

#include "core/error.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <limits>
#include <string>
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

/// Where a chunk's input comes from: straight from memory, or block by block from a ByteSource
/// into a buffer of one block (so no copy of the whole input is ever made).
struct Input {
  const unsigned char* data = nullptr;  ///< the whole input, or null
  const ByteSource* source = nullptr;   ///< used when data is null
  std::vector<unsigned char> buffer;    ///< one block, for `source`

  const unsigned char* block(std::size_t offset, std::size_t n) {
    if (!source) return data + offset;  // data may be null for an empty input
    buffer.resize(kGzipBlockBytes);
    (*source)(offset, n, buffer.data());
    return buffer.data();
  }
};

/// Output staging: deflate writes here, the bytes are appended to the chunk's output, so that only
/// the compressed bytes are ever touched (no buffer of the input's size is zero-filled).
constexpr std::size_t kStageBytes = std::size_t(256) << 10;

/// Hands the input bytes [begin, end) to `step(p, n, final_block)` block by block, each block's
/// CRC-32 into `c.crc`; once, with n = 0, for an empty range (the last chunk must still end the
/// stream). Stops when `step` returns false.
template <typename Step>
void for_each_block(Input& in, std::size_t begin, std::size_t end, Chunk& c, Step step) {
  std::size_t offset = begin;
  do {
    const std::size_t n = std::min(kGzipBlockBytes, end - offset);
    const unsigned char* p = in.block(offset, n);
    c.crc = crc32_z(c.crc, p, n);
    offset += n;
    if (!step(p, n, offset == end)) return;
  } while (offset < end);
}

#ifdef BS_HAVE_ISAL
/// deflate_chunk() by ISA-L's igzip at level min(level, 3) (its highest; run_length has no
/// counterpart there): the same raw-deflate chunk contract, other (equally valid) bytes.
void isal_deflate_chunk(Input& in, std::size_t begin, std::size_t end, bool last,
                        const GzipOptions& o, Chunk& c) {
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
  std::vector<unsigned char> stage(kStageBytes);
  for_each_block(in, begin, end, c, [&](const unsigned char* p, std::size_t n, bool final_block) {
    z.end_of_stream = (last && final_block) ? 1 : 0;
    // A chunk before the last ends on a byte boundary.
    z.flush = (final_block && !last) ? SYNC_FLUSH : NO_FLUSH;
    z.next_in = const_cast<unsigned char*>(p);  // ISA-L's API is not const-correct
    z.avail_in = static_cast<std::uint32_t>(n);
    // Called again while it fills the output (igzip's documented calling pattern).
    do {
      z.next_out = stage.data();
      z.avail_out = static_cast<std::uint32_t>(stage.size());
      if (isal_deflate(&z) != COMP_OK) {
        c.error = "isal_deflate failed";
        return false;
      }
      c.out.insert(c.out.end(), stage.data(), stage.data() + (stage.size() - z.avail_out));
    } while (z.avail_out == 0);
    if (z.avail_in != 0) c.error = "isal_deflate did not take its input";
    return c.error.empty();
  });
  if (c.error.empty() && last && z.internal_state.state != ZSTATE_END)
    c.error = "isal_deflate did not finish";
}
#endif

/// Deflates the input bytes [begin, end) block by block into `c`.
void deflate_chunk(Input& in, std::size_t begin, std::size_t end, bool last, const GzipOptions& o,
                   Chunk& c) {
  c.crc = crc32_z(0L, Z_NULL, 0);
#ifdef BS_HAVE_ISAL
  if (o.fast && o.level > 0) {
    isal_deflate_chunk(in, begin, end, last, o, c);
    return;
  }
#endif
  z_stream z{};
  if (deflateInit2(&z, o.level, Z_DEFLATED, -15, 8, o.run_length ? Z_RLE : Z_DEFAULT_STRATEGY) !=
      Z_OK) {
    c.error = "deflateInit2 failed";
    return;
  }
  std::vector<unsigned char> stage(kStageBytes);
  int rc = Z_OK;
  for_each_block(in, begin, end, c, [&](const unsigned char* p, std::size_t n, bool final_block) {
    const int flush = !final_block ? Z_NO_FLUSH : last ? Z_FINISH : Z_SYNC_FLUSH;
    z.next_in = const_cast<unsigned char*>(p);  // zlib's API is not const-correct
    z.avail_in = uInt(n);
    do {  // zlib's calling pattern: again while the output fills
      z.next_out = stage.data();
      z.avail_out = uInt(stage.size());
      rc = deflate(&z, flush);
      if (rc == Z_STREAM_ERROR) return false;
      c.out.insert(c.out.end(), stage.data(), stage.data() + (stage.size() - z.avail_out));
    } while (z.avail_out == 0);
    return z.avail_in == 0;
  });
  if (rc == Z_STREAM_ERROR || z.avail_in != 0 || (last && rc != Z_STREAM_END))
    c.error = "deflate failed";
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

namespace {

void gzip_input(Input& input, std::size_t size, const std::filesystem::path& target,
                const GzipOptions& options) {
  BS_VERIFY(options.level >= 0 && options.level <= 9 && options.threads >= 1,
            target.string() << ": gzip level must be 0-9 and threads >= 1, got " << options.level
                            << " and " << options.threads);
  // Chunks of whole blocks (at least one), each far below zlib's 32-bit counters.
  const std::size_t blocks =
      std::max<std::size_t>(1, (size + kGzipBlockBytes - 1) / kGzipBlockBytes);
  const std::size_t chunks = std::min<std::size_t>(std::size_t(options.threads), blocks);
  const auto first_byte = [&](std::size_t c) {  // of chunk c; chunks' first byte is its end
    return std::min(size, blocks * c / chunks * kGzipBlockBytes);
  };
  std::vector<Chunk> out(chunks);
  core::parallel_chunks(chunks, static_cast<int>(chunks), [&](std::size_t c) {
    Input own{input.data, input.source, {}};  // each chunk its own block buffer
    deflate_chunk(own, first_byte(c), first_byte(c + 1), c + 1 == chunks, options, out[c]);
  });
  uLong crc = out[0].crc;
  for (std::size_t c = 0; c < chunks; ++c) {
    BS_VERIFY(out[c].error.empty(), target.string() << ": cannot compress: " << out[c].error);
    if (c > 0) crc = crc32_combine(crc, out[c].crc, z_off_t(first_byte(c + 1) - first_byte(c)));
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

}  // namespace

void gzip_buffer(const void* data, std::size_t size, const std::filesystem::path& target,
                 const GzipOptions& options) {
  Input input;
  input.data = static_cast<const unsigned char*>(data);
  gzip_input(input, size, target, options);
}

void gzip_source(std::size_t size, const ByteSource& source, const std::filesystem::path& target,
                 const GzipOptions& options) {
  Input input;
  input.source = &source;
  gzip_input(input, size, target, options);
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

#ifdef BS_HAVE_ISAL
void gunzip_into(const std::vector<unsigned char>& in, const std::vector<GunzipPart>& parts,
                 const std::string& file) {
  inflate_state s;
  isal_inflate_init(&s);
  s.crc_flag = ISAL_GZIP;
  s.next_in = const_cast<unsigned char*>(in.data());  // NOLINT: ISA-L's API is not const
  s.avail_in = static_cast<std::uint32_t>(in.size());
  for (const GunzipPart& p : parts) {
    std::size_t done = 0;
    while (done < p.size) {
      s.next_out = p.data + done;
      s.avail_out = static_cast<std::uint32_t>(
          std::min<std::size_t>(p.size - done, std::numeric_limits<std::uint32_t>::max()));
      const std::uint32_t asked = s.avail_out, had = s.avail_in;
      const int status = isal_inflate(&s);
      BS_VERIFY(status == ISAL_DECOMP_OK,
                file << ": not a valid gzip stream (igzip status " << status << ")");
      BS_VERIFY(
          asked != s.avail_out || had != s.avail_in || s.block_state == ISAL_BLOCK_FINISH,
          file << ": ends before the data its header claims (truncated file?)");  // no progress
      done += asked - s.avail_out;
      if (done < p.size && s.block_state == ISAL_BLOCK_FINISH) {
        // The end of a member: another may follow (as in concatenated gzip files).
        BS_VERIFY(s.avail_in > 0,
                  file << ": ends before the data its header claims (truncated file?)");
        const std::uint8_t* rest = s.next_in;
        const std::uint32_t left = s.avail_in;
        isal_inflate_init(&s);
        s.crc_flag = ISAL_GZIP;
        s.next_in = const_cast<std::uint8_t*>(rest);  // NOLINT: as above
        s.avail_in = left;
      } else {
        BS_VERIFY(done == p.size || s.avail_in > 0,
                  file << ": ends before the data its header claims (truncated file?)");
      }
    }
  }
}
#else
void gunzip_into(const std::vector<unsigned char>& in, const std::vector<GunzipPart>& parts,
                 const std::string& file) {
  z_stream z{};
  BS_VERIFY(inflateInit2(&z, 15 + 16) == Z_OK, file << ": cannot start inflating");
  z.next_in = const_cast<Bytef*>(in.data());  // NOLINT: zlib's API is not const
  z.avail_in = static_cast<uInt>(in.size());
  try {
    for (const GunzipPart& p : parts) {
      std::size_t done = 0;
      while (done < p.size) {
        z.next_out = p.data + done;
        z.avail_out = static_cast<uInt>(
            std::min<std::size_t>(p.size - done, std::numeric_limits<uInt>::max()));
        const uInt asked = z.avail_out, had = z.avail_in;
        const int status = inflate(&z, Z_NO_FLUSH);
        BS_VERIFY(
            status != Z_BUF_ERROR || asked != z.avail_out || had != z.avail_in,
            file << ": ends before the data its header claims (truncated file?)");  // no progress
        done += asked - z.avail_out;
        if (status == Z_STREAM_END && done < p.size) {
          BS_VERIFY(z.avail_in > 0,
                    file << ": ends before the data its header claims (truncated file?)");
          BS_VERIFY(inflateReset(&z) == Z_OK, file << ": cannot inflate");
          continue;
        }
        BS_VERIFY(status == Z_OK || status == Z_STREAM_END,
                  file << ": not a valid gzip stream (zlib status " << status << ")");
        BS_VERIFY(done == p.size || z.avail_in > 0,
                  file << ": ends before the data its header claims (truncated file?)");
      }
    }
  } catch (...) {
    inflateEnd(&z);
    throw;
  }
  inflateEnd(&z);
}
#endif

}  // namespace brainshift::imaging
