#include "imaging/io/nifti_voxels.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <zlib.h>

#ifdef BS_HAVE_ISAL
#include <isa-l/igzip_lib.h>
#endif

namespace brainshift::imaging {
namespace {

std::size_t datatype_bytes(int datatype) {
  switch (datatype) {
    case 2:    // uint8
    case 256:  // int8
      return 1;
    case 4:    // int16
    case 512:  // uint16
      return 2;
    case 8:    // int32
    case 768:  // uint32
    case 16:   // float32
      return 4;
    case 64:  // float64
      return 8;
    default:
      return 0;
  }
}

std::vector<unsigned char> file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  BS_VERIFY(in, path.string() << ": cannot open");
  const std::streamoff size = in.tellg();
  BS_VERIFY(size >= 0, path.string() << ": cannot read");
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  in.seekg(0);
  BS_VERIFY(in.read(reinterpret_cast<char*>(bytes.data()), size), path.string() << ": cannot read");
  return bytes;
}

/// Inflates a gzip file (one or more members) into the consecutive outputs `parts` (each filled
/// completely, in order); stops when the last is full.
struct Part {
  unsigned char* data;
  std::size_t size;
};

#ifdef BS_HAVE_ISAL
void inflate_into(const std::vector<unsigned char>& in, const std::vector<Part>& parts,
                  const std::string& file) {
  inflate_state s;
  isal_inflate_init(&s);
  s.crc_flag = ISAL_GZIP;
  s.next_in = const_cast<unsigned char*>(in.data());  // NOLINT: ISA-L's API is not const
  s.avail_in = static_cast<std::uint32_t>(in.size());
  for (const Part& p : parts) {
    std::size_t done = 0;
    while (done < p.size) {
      s.next_out = p.data + done;
      s.avail_out = static_cast<std::uint32_t>(
          std::min<std::size_t>(p.size - done, std::numeric_limits<std::uint32_t>::max()));
      const std::uint32_t asked = s.avail_out, had = s.avail_in;
      const int status = isal_inflate(&s);
      BS_VERIFY(status == ISAL_DECOMP_OK,
                file << ": not a valid gzip stream (igzip status " << status << ")");
      BS_VERIFY(asked != s.avail_out || had != s.avail_in || s.block_state == ISAL_BLOCK_FINISH,
                file << ": ends before its voxels (truncated file?)");  // no progress
      done += asked - s.avail_out;
      if (done < p.size && s.block_state == ISAL_BLOCK_FINISH) {
        // The end of a member: another may follow (as in concatenated gzip files).
        BS_VERIFY(s.avail_in > 0, file << ": ends before its voxels (truncated file?)");
        const std::uint8_t* rest = s.next_in;
        const std::uint32_t left = s.avail_in;
        isal_inflate_init(&s);
        s.crc_flag = ISAL_GZIP;
        s.next_in = const_cast<std::uint8_t*>(rest);  // NOLINT: as above
        s.avail_in = left;
      } else {
        BS_VERIFY(done == p.size || s.avail_in > 0,
                  file << ": ends before its voxels (truncated file?)");
      }
    }
  }
}
#else
void inflate_into(const std::vector<unsigned char>& in, const std::vector<Part>& parts,
                  const std::string& file) {
  z_stream z{};
  BS_VERIFY(inflateInit2(&z, 15 + 16) == Z_OK, file << ": cannot start inflating");
  z.next_in = const_cast<Bytef*>(in.data());  // NOLINT: zlib's API is not const
  z.avail_in = static_cast<uInt>(in.size());
  try {
    for (const Part& p : parts) {
      std::size_t done = 0;
      while (done < p.size) {
        z.next_out = p.data + done;
        z.avail_out = static_cast<uInt>(
            std::min<std::size_t>(p.size - done, std::numeric_limits<uInt>::max()));
        const uInt asked = z.avail_out, had = z.avail_in;
        const int status = inflate(&z, Z_NO_FLUSH);
        BS_VERIFY(status != Z_BUF_ERROR || asked != z.avail_out || had != z.avail_in,
                  file << ": ends before its voxels (truncated file?)");  // no progress
        done += asked - z.avail_out;
        if (status == Z_STREAM_END && done < p.size) {
          BS_VERIFY(z.avail_in > 0, file << ": ends before its voxels (truncated file?)");
          BS_VERIFY(inflateReset(&z) == Z_OK, file << ": cannot inflate");
          continue;
        }
        BS_VERIFY(status == Z_OK || status == Z_STREAM_END,
                  file << ": not a valid gzip stream (zlib status " << status << ")");
        BS_VERIFY(done == p.size || z.avail_in > 0,
                  file << ": ends before its voxels (truncated file?)");
      }
    }
  } catch (...) {
    inflateEnd(&z);
    throw;
  }
  inflateEnd(&z);
}
#endif

template <class T>
void widen(const unsigned char* raw, std::size_t count, float* out) {
  for (std::size_t i = 0; i < count; ++i) {
    T v;
    std::memcpy(&v, raw + i * sizeof(T), sizeof(T));
    out[i] = static_cast<float>(v);
  }
}

void to_float(int datatype, const unsigned char* raw, std::size_t count, float* out) {
  switch (datatype) {
    case 2:
      return widen<std::uint8_t>(raw, count, out);
    case 256:
      return widen<std::int8_t>(raw, count, out);
    case 4:
      return widen<std::int16_t>(raw, count, out);
    case 512:
      return widen<std::uint16_t>(raw, count, out);
    case 8:
      return widen<std::int32_t>(raw, count, out);
    case 768:
      return widen<std::uint32_t>(raw, count, out);
    case 64:
      return widen<double>(raw, count, out);
    default:
      BS_UNREACHABLE();
  }
}

}  // namespace

bool nifti_voxels_readable(int datatype) { return datatype_bytes(datatype) > 0; }

bool read_nifti_voxels(const std::filesystem::path& path, const NiftiVoxelLayout& layout,
                       std::vector<float>& out) {
  const std::string file = path.string();
  const std::size_t bytes_per = datatype_bytes(layout.datatype);
  // A header with extensions past 1 MiB is left to VTK, which seeks to it, rather than held here.
  if (bytes_per == 0 || layout.offset < 4 || layout.offset > (std::int64_t(1) << 20)) return false;
  const auto offset = static_cast<std::size_t>(layout.offset);
  BS_VERIFY(layout.count <= std::numeric_limits<std::size_t>::max() / 8,
            file << ": " << layout.count << " voxels is more than can be read");
  const std::size_t data_bytes = layout.count * bytes_per;
  unsigned char magic[2] = {0, 0};
  {
    std::ifstream probe(path, std::ios::binary);
    BS_VERIFY(probe, file << ": cannot open");
    probe.read(reinterpret_cast<char*>(magic), 2);
  }
  const bool gzip = magic[0] == 0x1f && magic[1] == 0x8b;
  std::vector<unsigned char> head(offset);
  std::vector<float> values;
  std::vector<unsigned char> raw;
  unsigned char* target = nullptr;
  if (layout.datatype == 16) {
    values.resize(layout.count);
    target = reinterpret_cast<unsigned char*>(values.data());
  } else {
    raw.resize(data_bytes);
    target = raw.data();
  }
  if (gzip) {
    inflate_into(file_bytes(path), {{head.data(), offset}, {target, data_bytes}}, file);
  } else {  // read in place: the header's bytes, then the voxels straight into the buffer
    std::ifstream in(path, std::ios::binary);
    BS_VERIFY(in, file << ": cannot open");
    BS_VERIFY(
        in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(offset)) &&
            in.read(reinterpret_cast<char*>(target), static_cast<std::streamsize>(data_bytes)),
        file << ": shorter than its header and " << data_bytes
             << " bytes of voxels (truncated file?)");
  }
  std::int32_t sizeof_hdr = 0;
  std::memcpy(&sizeof_hdr, head.data(), 4);
  if (sizeof_hdr != 348 && sizeof_hdr != 540) return false;  // the other byte order: VTK's
  if (layout.datatype != 16) {
    values.resize(layout.count);
    to_float(layout.datatype, raw.data(), layout.count, values.data());
  }
  out = std::move(values);
  return true;
}

}  // namespace brainshift::imaging
