#include "imaging/io/image_io.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/cerr_capture.hpp"
#include "imaging/io/dicom_io.hpp"
#include "imaging/io/gzip_file.hpp"
#include "imaging/io/header_checks.hpp"
#include "imaging/io/image_frame.hpp"
#include "imaging/io/nifti_voxels.hpp"
#include "imaging/io/nifti_write.hpp"
#include "imaging/io/nrrd_io.hpp"
#include "imaging/io/vtk_error_capture.hpp"
#include "imaging/io/vtk_read_checks.hpp"

#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkMatrix3x3.h>
#include <vtkMatrix4x4.h>
#include <vtkNIFTIImageHeader.h>
#include <vtkNIFTIImageReader.h>
#include <vtkNIFTIImageWriter.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLImageDataReader.h>
#include <vtkXMLImageDataWriter.h>
#include <vtkmetaio/metaImage.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <system_error>
#include <type_traits>

namespace brainshift::imaging {
namespace {

std::string lower_name(const std::filesystem::path& path) {
  std::string name = path.filename().string();
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return name;
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

void verify_readable(const std::filesystem::path& path) {
  std::error_code ec;
  BS_VERIFY(std::filesystem::exists(path, ec), path.string() << ": no such file");
  BS_VERIFY(std::filesystem::is_regular_file(path, ec), path.string() << ": not a regular file");
  BS_VERIFY(std::filesystem::file_size(path, ec) > 0, path.string() << ": empty file");
}

/// Copies VTK point scalars into `volume.data` (float), checking the count.
void copy_scalars(vtkImageData* image, VolumeF& volume, const std::string& file) {
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  BS_VERIFY(scalars != nullptr, file << ": no voxel data");
  BS_VERIFY(scalars->GetNumberOfTuples() == volume.geometry.voxel_count(),
            file << ": " << scalars->GetNumberOfTuples() << " voxels of data for a "
                 << volume.geometry.voxel_count() << "-voxel grid (truncated file?)");
  volume.components = scalars->GetNumberOfComponents();
  const std::size_t values =
      std::size_t(volume.geometry.voxel_count()) * std::size_t(volume.components);
  if (auto* f = vtkFloatArray::SafeDownCast(scalars)) {
    volume.data.assign(f->GetPointer(0), f->GetPointer(0) + values);  // one pass, no zero fill
    return;
  }
  volume.data.resize(values);
  const vtkIdType n = scalars->GetNumberOfTuples();
  const int c = volume.components;
  for (vtkIdType t = 0; t < n; ++t)
    for (int k = 0; k < c; ++k)
      volume.data[std::size_t(t * c + k)] = static_cast<float>(scalars->GetComponent(t, k));
}

/// The voxels of `reader`'s file by read_nifti_voxels() where it reads them (VTK's slice order
/// the file's, one component), else false. A single file (.nii, .nii.gz) by then: image_format()
/// and verify_nifti_header()'s magic. \pre the reader's information updated.
bool read_voxels_directly(vtkNIFTIImageReader* reader, const std::filesystem::path& path,
                          const ImageGeometry& g, VolumeF& volume) {
  vtkNIFTIImageHeader* header = reader->GetNIFTIHeader();
  if (reader->GetQFac() != 1.0 || !nifti_voxels_readable(header->GetDataType())) return false;
  for (int d = 4; d <= 7; ++d)
    if (header->GetDim(d) > 1) return false;
  NiftiVoxelLayout layout;
  layout.offset = header->GetVoxOffset();
  layout.datatype = header->GetDataType();
  layout.count = static_cast<std::size_t>(g.voxel_count());
  if (!read_nifti_voxels(path, layout, volume.data)) return false;
  volume.components = 1;
  return true;
}

VolumeF read_nifti(const std::filesystem::path& path, bool direct_voxels = true) {
  const std::string file = path.string();
  verify_nifti_header(file);
  const VtkErrorCapture errors;
  vtkNew<vtkNIFTIImageReader> reader;
  BS_VERIFY(reader->CanReadFile(file.c_str()) != 0, file << ": not a NIfTI-1 file");
  reader->SetFileName(file.c_str());
  reader->UpdateInformation();  // the header: geometry, datatype, scaling
  BS_VERIFY(!errors.failed(), file << ": cannot read: " << errors.message());
  vtkNIFTIImageHeader* header = reader->GetNIFTIHeader();
  int extent[6];
  double spacing[3], origin[3];
  vtkInformation* info = reader->GetOutputInformation(0);
  info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  info->Get(vtkDataObject::SPACING(), spacing);
  info->Get(vtkDataObject::ORIGIN(), origin);
  const int dims[3] = {extent[1] - extent[0] + 1, extent[3] - extent[2] + 1,
                       extent[5] - extent[4] + 1};

  // VTK data coordinates x = origin + spacing·ijk map to the world by the 4×4 matrix.
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  vtkMatrix4x4* form = nullptr;
  if (header->GetSFormCode() > 0)
    form = reader->GetSFormMatrix();
  else if (header->GetQFormCode() > 0)
    form = reader->GetQFormMatrix();
  if (form != nullptr) {
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = form->GetElement(r, c);
  } else {
    logger().warn("{}: NIfTI without sform or qform: voxel spacing about the origin", file);
  }
  const Eigen::Matrix3d axes =
      m.topLeftCorner<3, 3>() * Vector3d(spacing[0], spacing[1], spacing[2]).asDiagonal();
  ImageGeometry g;
  g.size = {dims[0], dims[1], dims[2]};
  g.spacing = axes.colwise().norm().transpose();
  g.direction = axes * g.spacing.cwiseInverse().asDiagonal();
  g.origin = m.topLeftCorner<3, 3>() * Vector3d(origin[0], origin[1], origin[2]) +
             m.topRightCorner<3, 1>();
  BS_VERIFY(Vector3d(spacing[0], spacing[1], spacing[2]).allFinite(),
            file << ": non-finite pixdim spacing");
  verify_geometry(g, file);

  VolumeF volume;
  volume.geometry = g;
  if (!direct_voxels || !read_voxels_directly(reader, path, g, volume)) {
    update_reader(reader, file);
    BS_VERIFY(!errors.failed(), file << ": cannot read: " << errors.message());
    copy_scalars(reader->GetOutput(), volume, file);
  }
  const double slope = reader->GetRescaleSlope(), intercept = reader->GetRescaleIntercept();
  if (slope != 0.0 && std::isfinite(slope) && std::isfinite(intercept) &&
      (slope != 1.0 || intercept != 0.0))
    for (float& v : volume.data) v = static_cast<float>(v * slope + intercept);
  return volume;
}

VolumeF read_metaimage(const std::filesystem::path& path) {
  const std::string file = path.string();
  verify_metaimage_header(file);
  vtkmetaio::MetaImage meta;
  {  // The header alone first: its claims checked before the data are allocated and read.
    const CerrCapture messages;
    const bool read = meta.Read(file.c_str(), false);
    const std::string problem = messages.last_line();
    BS_VERIFY(read && problem.empty(), file << ": not a readable MetaImage ("
                                            << (problem.empty() ? "bad header" : problem) << ")");
    BS_VERIFY(meta.NDims() >= 2 && meta.ElementNumberOfChannels() >= 1,  // NDims 0: MetaIO's ÷ 0
              file << ": MetaImage with NDims " << meta.NDims() << ", channels "
                   << meta.ElementNumberOfChannels());
    double voxels = meta.ElementNumberOfChannels();
    for (int a = 0; a < meta.NDims(); ++a) {
      BS_VERIFY(meta.DimSize(a) >= 1, file << ": MetaImage DimSize " << meta.DimSize(a));
      voxels *= double(meta.DimSize(a));
    }
    int bytes = 0;
    vtkmetaio::MET_SizeOfType(meta.ElementType(), &bytes);
    BS_VERIFY(bytes > 0, file << ": MetaImage of an unsupported ElementType");
    const std::string data_file = meta.ElementDataFileName();
    // Only local data (.mha) is checked against its own file; a .mhd's data file by its size.
    if (data_file == "LOCAL")
      verify_claimed_bytes(file, voxels * bytes, 0.0, meta.CompressedData());
    else
      BS_VERIFY(voxels * bytes <= max_volume_bytes(),
                file << ": the header claims " << voxels * bytes << " bytes of voxels, over "
                     << "BRAINSHIFT_MAX_VOLUME_GB");
  }
  {
    const CerrCapture messages;
    const bool read = meta.Read(file.c_str(), true);
    const std::string problem = messages.last_line();
    BS_VERIFY(read && problem.empty(), file << ": not a readable MetaImage ("
                                            << (problem.empty() ? "bad header" : problem) << ")");
  }
  const int n = meta.NDims();
  BS_VERIFY(n == 2 || n == 3, file << ": MetaImage with " << n << " dimensions (2 or 3 supported)");
  ImageGeometry lps;
  Matrix3d d = Matrix3d::Identity();
  for (int a = 0; a < n; ++a) {
    lps.size[a] = meta.DimSize(a);
    lps.spacing[a] = meta.ElementSpacing(a);
    lps.origin[a] = meta.Offset(a);
    for (int b = 0; b < n; ++b) d(b, a) = meta.TransformMatrix()[a * n + b];
  }
  if (n == 2) lps.size[2] = 1;
  lps.direction = d;
  verify_geometry(lps, file);
  const ImageGeometry g = flip_lps_ras(lps);

  VolumeF volume(g, meta.ElementNumberOfChannels());
  const std::size_t count = volume.data.size();
  BS_VERIFY(meta.ElementData() != nullptr, file << ": MetaImage without voxel data");
  for (std::size_t i = 0; i < count; ++i)
    volume.data[i] = static_cast<float>(meta.ElementData(std::streamoff(i)));
  flip_vectors_lps_ras(volume);
  return volume;
}

VolumeF read_vti(const std::filesystem::path& path) {
  const std::string file = path.string();
  const VtkErrorCapture errors;
  vtkNew<vtkXMLImageDataReader> reader;
  BS_VERIFY(reader->CanReadFile(file.c_str()) != 0, file << ": not a VTK XML image data file");
  verify_vtk_xml_header(file);
  reader->SetFileName(file.c_str());
  update_reader(reader, file);
  BS_VERIFY(!errors.failed(), file << ": cannot read: " << errors.message());
  vtkImageData* image = reader->GetOutput();
  int dims[3];
  image->GetDimensions(dims);
  ImageGeometry g;
  g.size = {dims[0], dims[1], dims[2]};
  for (int a = 0; a < 3; ++a) {
    g.spacing[a] = image->GetSpacing()[a];
    g.origin[a] = image->GetOrigin()[a];
    for (int b = 0; b < 3; ++b) g.direction(a, b) = image->GetDirectionMatrix()->GetElement(a, b);
  }
  verify_geometry(g, file);
  VolumeF volume;
  volume.geometry = g;
  copy_scalars(image, volume, file);
  return volume;
}

/// A vtkImageData holding `volume`'s voxels (copied), with spacing and optionally the origin and
/// direction (NIfTI takes those from its matrices instead).
template <typename T>
vtkSmartPointer<vtkImageData> to_vtk_image(const Volume<T>& volume, bool with_frame) {
  const ImageGeometry& g = volume.geometry;
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(g.size[0], g.size[1], g.size[2]);
  image->SetSpacing(g.spacing[0], g.spacing[1], g.spacing[2]);
  if (with_frame) {
    image->SetOrigin(g.origin[0], g.origin[1], g.origin[2]);
    double d[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) d[3 * r + c] = g.direction(r, c);
    image->SetDirectionMatrix(d);
  }
  using Array = std::conditional_t<std::is_same_v<T, float>, vtkFloatArray, vtkUnsignedCharArray>;
  auto array = vtkSmartPointer<Array>::New();
  array->SetName("scalars");
  array->SetNumberOfComponents(volume.components);
  array->SetNumberOfTuples(g.voxel_count());
  std::copy(volume.data.begin(), volume.data.end(), array->GetPointer(0));
  image->GetPointData()->SetScalars(array);
  return image;
}

/// Runs `write(p)` with `p` = `temporary` + `extension` (writers that choose compression or
/// layout by extension), then renames it to `temporary`.
template <typename F>
void write_with_extension(const std::filesystem::path& temporary, const std::string& extension,
                          F&& write) {
  std::filesystem::path named = temporary;
  named += extension;
  try {
    write(named);
    std::filesystem::rename(named, temporary);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(named, ec);
    throw;
  }
}

template <typename T>
void write_nifti_by_vtk(const std::filesystem::path& target, const std::filesystem::path& temporary,
                        const Volume<T>& volume) {
  // VTK's writer compresses at zlib's default level 6, slowly; a .nii.gz is written as .nii by
  // VTK, then compressed by gzip_file() (level 1, run-length, 2 threads: as small on float volumes,
  // about 3x faster; docs/history/BENCHMARKS_NOTEBOOK.md "Speed").
  const bool gz = ends_with(lower_name(target), ".gz");
  std::filesystem::path raw = temporary;
  raw += ".raw";
  struct RemoveRaw {
    const std::filesystem::path& p;
    ~RemoveRaw() {
      std::error_code ec;
      std::filesystem::remove(p, ec);
    }
  } remove_raw{raw};
  const auto t_vtk = std::chrono::steady_clock::now();
  write_with_extension(gz ? raw : temporary, ".nii", [&](const std::filesystem::path& p) {
    const VtkErrorCapture errors;
    vtkNew<vtkMatrix4x4> m;
    const Eigen::Matrix4d world = [&] {
      Eigen::Matrix4d w = Eigen::Matrix4d::Identity();
      w.topLeftCorner<3, 3>() = volume.geometry.direction;
      w.topRightCorner<3, 1>() = volume.geometry.origin;
      return w;
    }();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m->SetElement(r, c, world(r, c));
    vtkNew<vtkNIFTIImageWriter> writer;
    writer->SetInputData(to_vtk_image(volume, /*with_frame=*/false));
    writer->SetSFormMatrix(m);
    writer->SetQFormMatrix(m);
    writer->SetFileName(p.string().c_str());
    writer->Write();
    BS_VERIFY(!errors.failed(), target.string() << ": cannot write NIfTI: " << errors.message());
  });
  const auto t_gz = std::chrono::steady_clock::now();
  if (gz) gzip_file(raw, temporary);
  logger().debug("write_nifti: VTK {:.3f} s, gzip {:.3f} s",
                 std::chrono::duration<double>(t_gz - t_vtk).count(),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t_gz).count());
}

template <typename T>
void write_nifti(const std::filesystem::path& target, const std::filesystem::path& temporary,
                 const Volume<T>& volume) {
  // VTK's own bytes without VTK writing them: no temporary .nii written and read back, no copy
  // of the volume into a vtkImageData.
  if (write_nifti_as_vtk(target, temporary, volume, ends_with(lower_name(target), ".gz"))) return;
  write_nifti_by_vtk(target, temporary, volume);
}

template <typename T>
void write_metaimage(const std::filesystem::path& target, const std::filesystem::path& temporary,
                     const Volume<T>& volume) {
  BS_VERIFY(!ends_with(lower_name(target), ".mhd"),
            target.string() << ": writing .mhd (detached data) is not supported; use .mha");
  const ImageGeometry lps = flip_lps_ras(volume.geometry);
  std::vector<T> data = volume.data;
  if constexpr (std::is_same_v<T, float>) {
    Volume<float> flipped = volume;
    flip_vectors_lps_ras(flipped);
    data = std::move(flipped.data);
  }
  const vtkmetaio::MET_ValueEnumType type =
      std::is_same_v<T, float> ? vtkmetaio::MET_FLOAT : vtkmetaio::MET_UCHAR;
  vtkmetaio::MetaImage meta(3, lps.size.data(), lps.spacing.data(), type, volume.components,
                            data.data());
  double tm[9];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) tm[3 * a + b] = lps.direction(b, a);
  meta.TransformMatrix(tm);
  meta.Offset(lps.origin.data());
  meta.BinaryData(true);
  meta.CompressedData(true);
  write_with_extension(temporary, ".mha", [&](const std::filesystem::path& p) {
    BS_VERIFY(meta.Write(p.string().c_str(), "LOCAL"), target.string()
                                                           << ": cannot write the MetaImage file");
  });
}

template <typename T>
void write_vti(const std::filesystem::path& target, const std::filesystem::path& temporary,
               const Volume<T>& volume) {
  const VtkErrorCapture errors;
  vtkNew<vtkXMLImageDataWriter> writer;
  writer->SetInputData(to_vtk_image(volume, /*with_frame=*/true));
  writer->SetDataModeToAppended();
  writer->SetFileName(temporary.string().c_str());
  BS_VERIFY(writer->Write() == 1 && !errors.failed(),
            target.string() << ": cannot write VTK image data: " << errors.message());
}

template <typename T>
void write_any(const std::filesystem::path& path, const Volume<T>& volume) {
  const ImageFormat format = image_format(path);
  const std::string file = path.string();
  BS_VERIFY(!volume.empty() && volume.geometry.voxel_count() > 0,
            file << ": cannot write an empty volume");
  BS_VERIFY(volume.data.size() ==
                std::size_t(volume.geometry.voxel_count()) * std::size_t(volume.components),
            file << ": volume holds " << volume.data.size() << " values for "
                 << volume.geometry.voxel_count() << " voxels × " << volume.components
                 << " components");
  verify_geometry(volume.geometry, file);
  write_atomically(path, [&](const std::filesystem::path& temporary) {
    switch (format) {
      case ImageFormat::NIFTI:
        write_nifti(path, temporary, volume);
        break;
      case ImageFormat::METAIMAGE:
        write_metaimage(path, temporary, volume);
        break;
      case ImageFormat::NRRD:
        write_nrrd(temporary, volume, NrrdSpace::RAS);
        break;
      case ImageFormat::VTI:
        write_vti(path, temporary, volume);
        break;
    }
  });
}

}  // namespace

ImageFormat image_format(const std::filesystem::path& path) {
  const std::string name = lower_name(path);
  if (ends_with(name, ".nii") || ends_with(name, ".nii.gz")) return ImageFormat::NIFTI;
  if (ends_with(name, ".mha") || ends_with(name, ".mhd")) return ImageFormat::METAIMAGE;
  if (ends_with(name, ".nrrd")) return ImageFormat::NRRD;
  if (ends_with(name, ".vti")) return ImageFormat::VTI;
  BS_THROW(path.string() << ": unknown image file extension (supported: .nii, .nii.gz, .mha, "
                            ".mhd, .nrrd, .vti)");
}

VolumeF read_nifti_by_vtk(const std::filesystem::path& path) {
  BS_VERIFY(image_format(path) == ImageFormat::NIFTI, path.string() << ": not a NIfTI file name");
  verify_readable(path);
  VolumeF volume = read_nifti(path, false);
  (void)orthonormalise_direction(volume.geometry, path.string());
  return volume;
}

VolumeF read_volume(const std::filesystem::path& path, std::string* header_note) {
  if (header_note != nullptr) header_note->clear();
  if (is_dicom_path(path)) return read_dicom_series(path);  // orthonormal there (dicom_io.cpp)
  const ImageFormat format = image_format(path);
  verify_readable(path);
  VolumeF volume = [&] {
    switch (format) {
      case ImageFormat::NIFTI:
        return read_nifti(path);
      case ImageFormat::METAIMAGE:
        return read_metaimage(path);
      case ImageFormat::NRRD:
        return read_nrrd(path);
      case ImageFormat::VTI:
        return read_vti(path);
    }
    BS_UNREACHABLE();
  }();
  const std::string note = orthonormalise_direction(volume.geometry, path.string());
  if (!note.empty()) logger().warn("{}", note);
  if (header_note != nullptr) *header_note = note;
  return volume;
}

LabelVolume read_labels(const std::filesystem::path& path) {
  const VolumeF volume = read_volume(path);
  const std::string file = path.string();
  BS_VERIFY(volume.components == 1,
            file << ": a label volume has one component, this one has " << volume.components);
  LabelVolume labels(volume.geometry);
  for (std::size_t v = 0; v < volume.data.size(); ++v) {
    const float value = volume.data[v];
    if (!(value == 0.0f || value == 1.0f || value == 2.0f || value == 3.0f)) {
      const auto& n = volume.geometry.size;
      const auto i = std::int64_t(v);
      BS_THROW(file << ": label value " << value << " at voxel (" << i % n[0] << ", "
                    << (i / n[0]) % n[1] << ", " << i / (std::int64_t(n[0]) * n[1])
                    << ") is not one of 0 background, 1 brain, 2 tumour, 3 ventricles");
    }
    labels.data[v] = static_cast<std::uint8_t>(value);
  }
  return labels;
}

void write_volume(const std::filesystem::path& path, const VolumeF& volume) {
  write_any(path, volume);
}

void write_labels(const std::filesystem::path& path, const LabelVolume& labels) {
  BS_VERIFY(labels.components == 1,
            path.string() << ": a label volume has one component, got " << labels.components);
  const auto bad = std::find_if(labels.data.begin(), labels.data.end(),
                                [](std::uint8_t v) { return v > VENTRICLES; });
  BS_VERIFY(bad == labels.data.end(),
            path.string() << ": label value " << int(*bad) << " is not one of 0, 1, 2, 3");
  write_any(path, labels);
}

void write_displacement_for_slicer(const std::filesystem::path& path,
                                   const VolumeF& displacement_ras) {
  const std::string file = path.string();
  BS_VERIFY(ends_with(lower_name(path), ".nrrd"),
            file << ": a displacement field for Slicer is written as .nrrd");
  BS_VERIFY(displacement_ras.components == 3,
            file << ": a displacement field has 3 components, got " << displacement_ras.components);
  BS_VERIFY(
      displacement_ras.data.size() == std::size_t(displacement_ras.geometry.voxel_count()) * 3 &&
          !displacement_ras.empty(),
      file << ": displacement field holds " << displacement_ras.data.size() << " values for "
           << displacement_ras.geometry.voxel_count() << " voxels × 3");
  BS_VERIFY(std::all_of(displacement_ras.data.begin(), displacement_ras.data.end(),
                        [](float v) { return std::isfinite(v); }),
            file << ": displacement field has non-finite values");
  verify_geometry(displacement_ras.geometry, file);
  write_atomically(path, [&](const std::filesystem::path& temporary) {
    // What current Slicer reads without asking: a displacement field (NIfTI intent 1006) in the
    // resampling sense (y + u(y) is where to sample the content shown at y).
    write_nrrd(temporary, displacement_ras, NrrdSpace::LPS,
               {{"intent_code", "1006"}, {"displacement field type", "resampling"}});
  });
}

}  // namespace brainshift::imaging
