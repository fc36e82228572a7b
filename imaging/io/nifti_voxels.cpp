#include "imaging/io/nifti_voxels.hpp"

#include "core/error.hpp"
#include "imaging/io/gzip_file.hpp"

#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <utility>

namespace brainshift::imaging {
namespace {

/// Calls f(T{}) with the C++ type of the NIfTI datatype code (2 uint8, 256 int8, 4 int16,
/// 512 uint16, 8 int32, 768 uint32, 16 float32, 64 float64); false for the other codes.
template <class F>
bool with_voxel_type(int datatype, F&& f) {
  switch (datatype) {
    case 2:
      f(std::uint8_t{});
      return true;
    case 256:
      f(std::int8_t{});
      return true;
    case 4:
      f(std::int16_t{});
      return true;
    case 512:
      f(std::uint16_t{});
      return true;
    case 8:
      f(std::int32_t{});
      return true;
    case 768:
      f(std::uint32_t{});
      return true;
    case 16:
      f(float{});
      return true;
    case 64:
      f(double{});
      return true;
    default:
      return false;
  }
}

std::size_t datatype_bytes(int datatype) {
  std::size_t bytes = 0;
  with_voxel_type(datatype, [&](auto t) { bytes = sizeof t; });
  return bytes;
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

template <class T>
void widen(const unsigned char* raw, std::size_t count, float* out) {
  for (std::size_t i = 0; i < count; ++i) {
    T v;
    std::memcpy(&v, raw + i * sizeof(T), sizeof(T));
    out[i] = static_cast<float>(v);
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
    gunzip_into(file_bytes(path), {{head.data(), offset}, {target, data_bytes}}, file);
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
    with_voxel_type(layout.datatype,
                    [&](auto t) { widen<decltype(t)>(raw.data(), layout.count, values.data()); });
  }
  out = std::move(values);
  return true;
}

}  // namespace brainshift::imaging
