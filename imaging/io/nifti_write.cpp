#include "imaging/io/nifti_write.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "imaging/io/gzip_file.hpp"
#include "imaging/io/vtk_error_capture.hpp"

#include <vtkMath.h>
#include <vtkNIFTIImageWriter.h>
#include <vtkNew.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::imaging {
namespace {

/// The description VTK's NIfTI writer puts in every header ("VTK" and its version).
std::string vtk_nifti_description() {
  static const std::string d = [] {
    const VtkErrorCapture errors;
    vtkNew<vtkNIFTIImageWriter> w;
    return std::string(w->GetDescription() != nullptr ? w->GetDescription() : "");
  }();
  return d;
}

/// The 352 bytes (header and the empty extension flag) that vtkNIFTIImageWriter writes before
/// the voxels of `volume` in write_nifti()'s set-up (qform and sform both the world matrix, image
/// origin 0, no rescaling), built field by field as its GenerateHeader() does, so that the file
/// can be written without VTK writing (and write_nifti() re-reading) the whole volume: see the
/// test NiftiWriter.HeaderAndVoxelsAreVtksByteForByte. Nothing for the cases VTK treats
/// specially (2 components, unsigned char with 3 or 4, axes longer than 32767).
template <typename T>
std::optional<std::array<char, 352>> nifti_header_as_vtk(const Volume<T>& volume) {
  const ImageGeometry& g = volume.geometry;
  const int nc = volume.components;
  if (nc < 1 || nc == 2 || (std::is_same_v<T, std::uint8_t> && (nc == 3 || nc == 4)) ||
      g.size.maxCoeff() > std::numeric_limits<std::int16_t>::max())
    return std::nullopt;
  std::array<char, 352> h{};
  const auto put = [&h](std::size_t offset, auto value) {
    std::memcpy(h.data() + offset, &value, sizeof value);
  };
  put(0, std::int32_t{348});  // sizeof_hdr
  const std::int16_t dim[8] = {std::int16_t(nc == 1 ? (g.size[2] == 1 ? 2 : 3) : 5),
                               std::int16_t(g.size[0]),
                               std::int16_t(g.size[1]),
                               std::int16_t(g.size[2]),
                               1,
                               std::int16_t(nc),
                               1,
                               1};
  std::memcpy(h.data() + 40, dim, sizeof dim);
  put(70, std::int16_t(std::is_same_v<T, float> ? 16 : 2));  // datatype: FLOAT32 / UINT8
  put(72, std::int16_t(std::is_same_v<T, float> ? 32 : 8));  // bitpix
  // pixdim: qfac 1, the spacing, then 1 (VTK's header holds doubles, written as float)
  const double pixdim[8] = {1.0, g.spacing[0], g.spacing[1], g.spacing[2], 1.0, 1.0, 1.0, 1.0};
  for (int i = 0; i < 8; ++i) put(76 + 4 * std::size_t(i), float(pixdim[i]));
  put(108, float(352));  // vox_offset
  put(112, float(1));    // scl_slope (VTK's blank header), scl_inter 0
  const std::string d = vtk_nifti_description();
  std::memcpy(h.data() + 148, d.data(), std::min<std::size_t>(d.size(), 79));
  put(252, std::int16_t{1});  // qform_code: scanner
  put(254, std::int16_t{2});  // sform_code: aligned
  double r[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) r[a][b] = g.direction(a, b);
  double quat[4];
  vtkMath::Matrix3x3ToQuaternion(r, quat);
  if (quat[0] < 0)
    for (double& q : quat) q = -q;
  const double qform[6] = {quat[1], quat[2], quat[3], g.origin[0], g.origin[1], g.origin[2]};
  for (int i = 0; i < 6; ++i) put(256 + 4 * std::size_t(i), float(qform[i]));
  for (int a = 0; a < 3; ++a) {  // srow_x, srow_y, srow_z
    for (int b = 0; b < 3; ++b)
      put(280 + 16 * std::size_t(a) + 4 * std::size_t(b), float(r[a][b] * pixdim[b + 1]));
    put(280 + 16 * std::size_t(a) + 12, float(g.origin[a]));
  }
  std::memcpy(h.data() + 344, "n+1", 4);  // magic; bytes 348-351 (extension flag) stay 0
  return h;
}

/// The NIfTI file's bytes [offset, offset + n) into `out`: header, then the voxels, component by
/// component (NIfTI's vector dimension varies slowest) as vtkNIFTIImageWriter orders them. Made
/// block by block as the file is written, so no copy of the whole file is held (a displacement
/// field at the MRI's size is 100 MB). `offset` past the header is a whole number of voxels
/// (the header's 352 bytes are, and the blocks start at multiples of kGzipBlockBytes).
template <typename T>
void nifti_fill(const std::array<char, 352>& header, const Volume<T>& volume, std::size_t offset,
                std::size_t n, unsigned char* out) {
  if (offset < header.size()) {
    const std::size_t k = std::min(n, header.size() - offset);
    std::memcpy(out, header.data() + offset, k);
    offset += k;
    out += k;
    n -= k;
  }
  BS_VERIFY((offset - header.size()) % sizeof(T) == 0 && n % sizeof(T) == 0,
            "nifti_fill: a block that splits a voxel");
  const std::size_t voxels = std::size_t(volume.geometry.voxel_count());
  const auto nc = std::size_t(volume.components);
  const std::size_t first = (offset - header.size()) / sizeof(T), count = n / sizeof(T);
  T* dst = reinterpret_cast<T*>(out);  // blocks are allocated for any scalar type
  if (nc == 1) {
    std::memcpy(dst, volume.data.data() + first, count * sizeof(T));
    return;
  }
  std::size_t c = first / voxels, v = first % voxels;
  for (std::size_t i = 0; i < count; ++i) {
    dst[i] = volume.data[v * nc + c];
    if (++v == voxels) {
      v = 0;
      ++c;
    }
  }
}

}  // namespace

template <typename T>
bool write_nifti_as_vtk(const std::filesystem::path& target, const std::filesystem::path& temporary,
                        const Volume<T>& volume, bool gz) {
  const auto header = nifti_header_as_vtk(volume);
  if (!header) return false;
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t size = header->size() + std::size_t(volume.geometry.voxel_count()) *
                                                std::size_t(volume.components) * sizeof(T);
  const ByteSource fill = [&](std::size_t offset, std::size_t n, unsigned char* out) {
    nifti_fill(*header, volume, offset, n, out);
  };
  if (gz) {
    gzip_source(size, fill, temporary);
  } else {
    std::ofstream f(temporary, std::ios::binary | std::ios::trunc);
    std::vector<unsigned char> block(kGzipBlockBytes);
    for (std::size_t offset = 0; offset < size && f.good(); offset += kGzipBlockBytes) {
      const std::size_t n = std::min(kGzipBlockBytes, size - offset);
      fill(offset, n, block.data());
      f.write(reinterpret_cast<const char*>(block.data()), std::streamsize(n));
    }
    f.close();
    BS_VERIFY(f.good(), target.string() << ": cannot write (disk full?)");
  }
  logger().debug("write_nifti: {:.3f} s",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return true;
}

template bool write_nifti_as_vtk(const std::filesystem::path&, const std::filesystem::path&,
                                 const Volume<float>&, bool);
template bool write_nifti_as_vtk(const std::filesystem::path&, const std::filesystem::path&,
                                 const Volume<std::uint8_t>&, bool);

}  // namespace brainshift::imaging
