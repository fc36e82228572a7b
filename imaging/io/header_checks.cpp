#include "imaging/io/header_checks.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <zlib.h>

namespace brainshift::imaging {

double max_volume_bytes() {
  double gib = 4.0;
  if (const char* v = std::getenv("BRAINSHIFT_MAX_VOLUME_GB")) {
    char* end = nullptr;
    const double x = std::strtod(v, &end);
    if (end != v && std::isfinite(x) && x > 0) gib = x;
  }
  return gib * double(1ULL << 30);
}

void verify_claimed_bytes(const std::string& file, double claimed, double offset, bool compressed) {
  std::error_code ec;
  const double size = double(std::filesystem::file_size(file, ec));
  BS_VERIFY(claimed <= max_volume_bytes(),
            file << ": the header claims " << claimed / double(1ULL << 30)
                 << " GiB of voxels, over the " << max_volume_bytes() / double(1ULL << 30)
                 << " GiB this tool reads (BRAINSHIFT_MAX_VOLUME_GB)");
  if (compressed)
    BS_VERIFY(claimed <= 1032.0 * size + 1024.0,
              file << ": the header claims " << claimed << " bytes of voxels from a " << size
                   << "-byte compressed file, more than deflate can hold (corrupt header)");
  else
    BS_VERIFY(claimed + offset <= size, file << ": truncated: the header claims " << claimed
                                             << " bytes of voxels after byte " << offset
                                             << ", the file holds " << size);
}

void verify_vtk_xml_header(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  BS_VERIFY(in, file << ": cannot open");
  std::string head(std::size_t(1) << 20, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(std::size_t(in.gcount()));
  if (const auto appended = head.find("<AppendedData"); appended != std::string::npos)
    head.resize(appended);
  const bool compressed = head.find("compressor=") != std::string::npos;
  // Bytes in memory per item (Float64 points; cells: a type, an offset and four ids) and the
  // values each takes on disk, at one byte per value at the least.
  struct Count {
    const char* name;
    double memory, values;
  };
  constexpr Count counts[] = {{"NumberOfPoints", 24, 3}, {"NumberOfCells", 41, 3},
                              {"NumberOfVerts", 16, 2},  {"NumberOfLines", 32, 3},
                              {"NumberOfStrips", 40, 4}, {"NumberOfPolys", 40, 4}};
  double memory = 0.0, values = 0.0;
  for (std::size_t piece = head.find("<Piece"); piece != std::string::npos;
       piece = head.find("<Piece", piece + 6)) {
    const std::size_t end = std::min(head.find('>', piece), head.size());
    const std::string tag = head.substr(piece, end - piece);
    for (const Count& c : counts) {
      const std::string key = std::string(" ") + c.name + "=\"";
      const std::size_t at = tag.find(key);
      if (at == std::string::npos) continue;
      const char* text = tag.c_str() + at + key.size();
      char* stop = nullptr;
      const double n = std::strtod(text, &stop);
      BS_VERIFY(stop != text && *stop == '"' && std::isfinite(n) && n >= 0.0 && n == std::floor(n),
                file << ": " << c.name << " \""
                     << std::string(text, std::strcspn(text, "\"")).substr(0, 32)
                     << "\" is not a count");
      memory += n * c.memory;
      values += n * c.values;
    }
  }
  // Image data: the voxels of WholeExtent="x0 x1 y0 y1 z0 z1" (read as float, one value each).
  if (const std::size_t at = head.find(" WholeExtent=\""); at != std::string::npos) {
    const char* text = head.c_str() + at + 14;
    double voxels = 1.0;
    for (int a = 0; a < 3; ++a) {
      char* stop = nullptr;
      const double lo = std::strtod(text, &stop);
      const char* mid = stop;
      const double hi = std::strtod(mid, &stop);
      BS_VERIFY(stop != mid && mid != text && std::isfinite(lo) && std::isfinite(hi) &&
                    lo == std::floor(lo) && hi == std::floor(hi) && hi >= lo - 1.0,
                file << ": WholeExtent is not three integer ranges");
      voxels *= hi - lo + 1.0;
      text = stop;
    }
    memory += 4.0 * voxels;
    values += voxels;
  }
  BS_VERIFY(memory <= max_volume_bytes(),
            file << ": the header claims " << memory / double(1ULL << 30)
                 << " GiB of points, cells or voxels, over the "
                 << max_volume_bytes() / double(1ULL << 30)
                 << " GiB this tool reads (BRAINSHIFT_MAX_VOLUME_GB)");
  std::error_code ec;
  const double size = double(std::filesystem::file_size(file, ec));
  BS_VERIFY(values <= (compressed ? 1032.0 * size + 1024.0 : size),
            file << ": the header claims " << values
                 << " values of points, cells or voxels, more than a " << size << "-byte "
                 << (compressed ? "compressed " : "") << "file can hold (corrupt header)");
}

void verify_nifti_header(const std::string& file) {
  unsigned char h[348] = {};
  gzFile in = gzopen(file.c_str(), "rb");
  BS_VERIFY(in != nullptr, file << ": cannot open");
  const int got = gzread(in, h, sizeof h);
  const bool compressed = gzdirect(in) == 0;
  gzclose(in);
  BS_VERIFY(got == int(sizeof h),
            file << ": not a NIfTI-1 file (shorter than its 348-byte header)");
  std::int32_t sizeof_hdr = 0;
  std::memcpy(&sizeof_hdr, h, 4);
  const bool swap = sizeof_hdr != 348 && sizeof_hdr != 540;
  if (swap) sizeof_hdr = std::int32_t(__builtin_bswap32(std::uint32_t(sizeof_hdr)));
  if (sizeof_hdr == 540) return;  // NIfTI-2: VTK's reader checks it
  BS_VERIFY(sizeof_hdr == 348, file << ": not a NIfTI-1 file (header size " << sizeof_hdr << ")");
  const auto i16 = [&](int at) {
    std::uint16_t v = 0;
    std::memcpy(&v, h + at, 2);
    return std::int16_t(swap ? __builtin_bswap16(v) : v);
  };
  const auto f32 = [&](int at) {
    std::uint32_t v = 0;
    std::memcpy(&v, h + at, 4);
    if (swap) v = __builtin_bswap32(v);
    float f = 0;
    std::memcpy(&f, &v, 4);
    return double(f);
  };
  const int ndim = i16(40);
  BS_VERIFY(ndim >= 1 && ndim <= 7, file << ": NIfTI dim[0] = " << ndim << " (1 to 7)");
  double voxels = 1;
  for (int a = 1; a <= ndim; ++a) {
    const int d = i16(40 + 2 * a);
    BS_VERIFY(d >= 1, file << ": NIfTI dim[" << a << "] = " << d << " (must be >= 1)");
    voxels *= double(d);
  }
  const int bitpix = i16(72);
  BS_VERIFY(bitpix > 0 && bitpix % 8 == 0 && bitpix <= 128,
            file << ": NIfTI bitpix " << bitpix << " is not a whole number of bytes");
  for (int a = 1; a <= std::min(ndim, 3); ++a) {
    const double p = f32(76 + 4 * a);
    BS_VERIFY(std::isfinite(p) && p != 0.0, file << ": NIfTI pixdim[" << a << "] = " << p
                                                 << " (spacing must be finite, non-zero)");
  }
  const double offset = std::max(352.0, f32(108));
  const bool single_file = std::memcmp(h + 344, "n+1", 4) == 0;  // else a .hdr with its .img
  if (single_file)
    verify_claimed_bytes(file, voxels * bitpix / 8.0, offset, compressed);
  else  // the ceiling alone
    BS_VERIFY(voxels * bitpix / 8.0 <= max_volume_bytes(),
              file << ": the header claims " << voxels * bitpix / 8.0
                   << " bytes of voxels, over BRAINSHIFT_MAX_VOLUME_GB");
}

}  // namespace brainshift::imaging
