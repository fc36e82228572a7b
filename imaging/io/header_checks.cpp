#include "imaging/io/header_checks.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cctype>
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

void verify_metaimage_header(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  BS_VERIFY(in, file << ": cannot open");
  const auto trim = [](std::string t) {
    const auto b = t.find_first_not_of(" \t\r");
    const auto e = t.find_last_not_of(" \t\r");
    return b == std::string::npos ? std::string() : t.substr(b, e - b + 1);
  };
  // Every line "Key = value" (MetaIO copies keys and values into 255-byte buffers and reads a
  // key up to the next '=', across lines: a long one overflowed there — fuzzing).
  std::string line;
  bool data = false;
  for (int n = 1; n <= 1000 && !data && std::getline(in, line); ++n) {
    if (trim(line).empty()) continue;
    const auto eq = line.find('=');
    const std::string key = eq == std::string::npos ? std::string() : trim(line.substr(0, eq));
    const bool word = !key.empty() && key.size() <= 64 &&
                      std::all_of(key.begin(), key.end(),
                                  [](unsigned char c) { return std::isalnum(c) != 0 || c == '_'; });
    BS_VERIFY(word && line.size() <= 250, file << ": MetaImage header line " << n
                                               << " is not 'Key = value' (a word, '=', at "
                                               << "most 250 characters)");
    const std::string value = trim(line.substr(eq + 1));
    data = key == "ElementDataFile";
    const auto whole = [&](long lo, long hi) {
      char* end = nullptr;
      const long v = std::strtol(value.c_str(), &end, 10);
      return !value.empty() && *end == '\0' && v >= lo && v <= hi;
    };
    if (key == "NDims")
      BS_VERIFY(whole(2, 3),
                file << ": MetaImage NDims \"" << value.substr(0, 24) << "\" (2 or 3 supported)");
    if (key == "ElementNumberOfChannels")
      BS_VERIFY(whole(1, 16), file << ": MetaImage ElementNumberOfChannels \""
                                   << value.substr(0, 24) << "\" (1 to 16)");
    if (data) {  // the data follow: LOCAL, or one file beside the header
      BS_VERIFY(value == "LOCAL" || (!value.empty() && value.find('%') == std::string::npos &&
                                     value.rfind("LIST", 0) != 0),
                file << ": MetaImage ElementDataFile \"" << value.substr(0, 24)
                     << "\" (LOCAL or one data file; file patterns and lists are not read)");
    }
  }
  BS_VERIFY(data, file << ": MetaImage header without an ElementDataFile line");
}

void verify_nifti_header(const std::string& file) {
  unsigned char h[540] = {};
  gzFile in = gzopen(file.c_str(), "rb");
  BS_VERIFY(in != nullptr, file << ": cannot open");
  const int got = gzread(in, h, sizeof h);
  const bool compressed = gzdirect(in) == 0;
  gzclose(in);
  BS_VERIFY(got >= 348, file << ": not a NIfTI file (shorter than a 348-byte header)");
  std::int32_t sizeof_hdr = 0;
  std::memcpy(&sizeof_hdr, h, 4);
  const bool swap = sizeof_hdr != 348 && sizeof_hdr != 540;
  if (swap) sizeof_hdr = std::int32_t(__builtin_bswap32(std::uint32_t(sizeof_hdr)));
  BS_VERIFY(sizeof_hdr == 348 || sizeof_hdr == 540,
            file << ": not a NIfTI file (header size " << sizeof_hdr << ")");
  const bool two = sizeof_hdr == 540;  // NIfTI-2: 64-bit dimensions, double spacing
  BS_VERIFY(!two || got == 540, file << ": not a NIfTI-2 file (shorter than its 540-byte header)");
  const auto bytes = [&](int at, int n) {
    std::uint64_t v = 0;
    std::memcpy(&v, h + at, std::size_t(n));
    if (swap) v = __builtin_bswap64(v) >> (64 - 8 * n);
    return v;
  };
  const auto i16 = [&](int at) { return double(std::int16_t(bytes(at, 2))); };
  const auto i64 = [&](int at) { return double(std::int64_t(bytes(at, 8))); };
  const auto f32 = [&](int at) {
    const auto v = std::uint32_t(bytes(at, 4));
    float f = 0;
    std::memcpy(&f, &v, 4);
    return double(f);
  };
  const auto f64 = [&](int at) {
    const std::uint64_t v = bytes(at, 8);
    double d = 0;
    std::memcpy(&d, &v, 8);
    return d;
  };
  // Field offsets: NIfTI-1 | NIfTI-2.
  const auto dim = [&](int a) { return two ? i64(16 + 8 * a) : i16(40 + 2 * a); };
  const auto pixdim = [&](int a) { return two ? f64(104 + 8 * a) : f32(76 + 4 * a); };
  const char* version = two ? "NIfTI-2" : "NIfTI";
  const double ndim = dim(0);
  BS_VERIFY(ndim >= 1 && ndim <= 7, file << ": " << version << " dim[0] = " << ndim << " (1 to 7)");
  double voxels = 1;
  for (int a = 1; a <= int(ndim); ++a) {
    const double d = dim(a);
    BS_VERIFY(d >= 1, file << ": " << version << " dim[" << a << "] = " << d << " (must be >= 1)");
    voxels *= d;
  }
  // The scalar types that VTK's reader takes (an unknown code crashed it: fuzzing) and their
  // bits; complex and 128-bit types are refused.
  const int datatype = int(i16(two ? 12 : 70));
  int datatype_bits = 0;
  switch (datatype) {
    case 2:
    case 256:
      datatype_bits = 8;
      break;  // uint8, int8
    case 4:
    case 512:
      datatype_bits = 16;
      break;  // int16, uint16
    case 8:
    case 16:
    case 768:
    case 2304:
      datatype_bits = 32;
      break;  // int32, float32, uint32, RGBA
    case 64:
    case 1024:
    case 1280:
      datatype_bits = 64;
      break;  // float64, int64, uint64
    case 128:
      datatype_bits = 24;
      break;  // RGB24
    default:
      break;
  }
  BS_VERIFY(datatype_bits > 0, file << ": " << version << " datatype " << datatype
                                    << " is not a scalar type this tool reads (integers of 8 to 64 "
                                       "bits, float32, float64, RGB)");
  const int bitpix = int(i16(two ? 14 : 72));
  BS_VERIFY(bitpix > 0 && bitpix % 8 == 0 && bitpix <= 128,
            file << ": " << version << " bitpix " << bitpix << " is not a whole number of bytes");
  for (int a = 1; a <= std::min(int(ndim), 3); ++a) {
    const double p = pixdim(a);
    BS_VERIFY(std::isfinite(p) && p != 0.0, file << ": " << version << " pixdim[" << a << "] = "
                                                 << p << " (spacing must be finite, non-zero)");
  }
  const double offset = std::max(two ? 544.0 : 352.0, two ? i64(168) : f32(108));
  // brainshift reads .nii and .nii.gz, single files: the magic is "n+1" ("n+2"). (A .hdr/.img
  // pair's "ni1" in a .nii let VTK allocate what the header claims before it found no .img.)
  BS_VERIFY(two ? std::memcmp(h + 4, "n+2", 4) == 0 : std::memcmp(h + 344, "n+1", 4) == 0,
            file << ": not a single-file " << version << " (magic is not \""
                 << (two ? "n+2" : "n+1") << "\"; .hdr/.img pairs are not read)");
  verify_claimed_bytes(file, voxels * std::max(bitpix, datatype_bits) / 8.0, offset, compressed);
}

}  // namespace brainshift::imaging
