#include "imaging/io/header_checks.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
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
