#include "imaging/io/dicom_io.hpp"

#include "core/error.hpp"
#include "imaging/io/image_frame.hpp"
#include "imaging/io/text_util.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmScanner.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>
#include <gdcmUIDGenerator.h>
#include <gdcmWriter.h>
#include <map>
#include <sstream>
#include <vector>

namespace brainshift::imaging {
namespace {

namespace fs = std::filesystem;

/// A string element's value without DICOM's padding (trailing spaces and NULs); "" if absent.
std::string text(const gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element) {
  const gdcm::Tag tag(group, element);
  if (!ds.FindDataElement(tag)) return {};
  const gdcm::ByteValue* bv = ds.GetDataElement(tag).GetByteValue();
  if (!bv || !bv->GetPointer()) return {};
  std::string s(bv->GetPointer(), bv->GetLength());
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  while (!s.empty() && s.front() == ' ') s.erase(s.begin());
  return s;
}

/// A decimal string's first value (a DS element), or `fallback` when absent or empty.
double decimal(const gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element, double fallback,
               const std::string& file, const char* name) {
  const std::string s = text(ds, group, element);
  if (s.empty()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  BS_VERIFY(end != s.c_str() && std::isfinite(v),
            file << ": DICOM " << name << " '" << s << "' is not a number");
  return v;
}

/// One slice as read: where it is and its values (rescaled), row by row.
struct Slice {
  std::string file;
  Vector3d position_lps;
  std::array<double, 6> orientation{};
  double spacing_x = 0, spacing_y = 0, thickness = 0;
  unsigned columns = 0, rows = 0;
  std::vector<float> values;
};

/// The source's identity from one of its files (the series UID comes from the scan).
void fill_info(const gdcm::DataSet& ds, DicomSeriesInfo& info) {
  info.patient_name = text(ds, 0x0010, 0x0010);
  info.patient_id = text(ds, 0x0010, 0x0020);
  info.patient_birth_date = text(ds, 0x0010, 0x0030);
  info.patient_sex = text(ds, 0x0010, 0x0040);
  info.study_instance_uid = text(ds, 0x0020, 0x000d);
  info.study_date = text(ds, 0x0008, 0x0020);
  info.study_time = text(ds, 0x0008, 0x0030);
  info.study_id = text(ds, 0x0020, 0x0010);
  info.accession_number = text(ds, 0x0008, 0x0050);
  info.study_description = text(ds, 0x0008, 0x1030);
  info.frame_of_reference_uid = text(ds, 0x0020, 0x0052);
  info.series_description = text(ds, 0x0008, 0x103e);
  info.modality = text(ds, 0x0008, 0x0060);
  const std::string number = text(ds, 0x0020, 0x0011);
  info.series_number = number.empty() ? 0 : std::atoi(number.c_str());
}

Slice read_slice(const std::string& file, DicomSeriesInfo* info = nullptr) {
  // GDCM's own notes (e.g. on the Modality LUT of MR images, which we apply ourselves) would
  // reach stderr; errors still come back as a failed read.
  gdcm::Trace::WarningOff();
  gdcm::ImageReader reader;
  reader.SetFileName(file.c_str());
  BS_VERIFY(reader.Read(), file << ": not a DICOM image GDCM can decode");
  const gdcm::Image& image = reader.GetImage();
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  if (info) fill_info(ds, *info);
  Slice s;
  s.file = file;
  BS_VERIFY(image.GetNumberOfDimensions() == 2 ||
                (image.GetNumberOfDimensions() == 3 && image.GetDimension(2) == 1),
            file << ": multi-frame DICOM images (" << image.GetDimension(2)
                 << " frames) are not supported; export the series as single-frame images");
  s.columns = image.GetDimension(0);
  s.rows = image.GetDimension(1);
  BS_VERIFY(s.columns > 0 && s.rows > 0, file << ": DICOM image of size 0");
  const gdcm::PixelFormat& pf = image.GetPixelFormat();
  BS_VERIFY(pf.GetSamplesPerPixel() == 1,
            file << ": DICOM image with " << pf.GetSamplesPerPixel()
                 << " samples per pixel (colour); a scalar image is needed");
  BS_VERIFY(ds.FindDataElement(gdcm::Tag(0x0020, 0x0032)) &&
                ds.FindDataElement(gdcm::Tag(0x0020, 0x0037)),
            file << ": DICOM image without Image Position / Orientation (Patient)");
  const double* origin = image.GetOrigin();
  s.position_lps = Vector3d(origin[0], origin[1], origin[2]);
  const double* cosines = image.GetDirectionCosines();
  for (int a = 0; a < 6; ++a) s.orientation[std::size_t(a)] = cosines[a];
  s.spacing_x = image.GetSpacing(0);
  s.spacing_y = image.GetSpacing(1);
  s.thickness = decimal(ds, 0x0018, 0x0050, 0.0, file, "Slice Thickness");
  const double slope = decimal(ds, 0x0028, 0x1053, 1.0, file, "Rescale Slope");
  const double intercept = decimal(ds, 0x0028, 0x1052, 0.0, file, "Rescale Intercept");

  std::vector<char> buffer(image.GetBufferLength());
  BS_VERIFY(image.GetBuffer(buffer.data()), file << ": cannot decode the DICOM pixel data");
  const std::size_t n = std::size_t(s.columns) * s.rows;
  s.values.resize(n);
  const auto convert = [&](auto zero) {
    using T = decltype(zero);
    BS_VERIFY(buffer.size() >= n * sizeof(T), file << ": DICOM pixel data holds " << buffer.size()
                                                   << " bytes, expected " << n * sizeof(T));
    for (std::size_t i = 0; i < n; ++i) {
      T v;
      std::memcpy(&v, buffer.data() + i * sizeof(T), sizeof(T));
      s.values[i] = float(double(v) * slope + intercept);
    }
  };
  switch (pf.GetScalarType()) {
    case gdcm::PixelFormat::UINT8:
      convert(std::uint8_t{});
      break;
    case gdcm::PixelFormat::INT8:
      convert(std::int8_t{});
      break;
    case gdcm::PixelFormat::UINT12:
    case gdcm::PixelFormat::UINT16:
      convert(std::uint16_t{});
      break;
    case gdcm::PixelFormat::INT12:
    case gdcm::PixelFormat::INT16:
      convert(std::int16_t{});
      break;
    case gdcm::PixelFormat::UINT32:
      convert(std::uint32_t{});
      break;
    case gdcm::PixelFormat::INT32:
      convert(std::int32_t{});
      break;
    case gdcm::PixelFormat::FLOAT32:
      convert(float{});
      break;
    case gdcm::PixelFormat::FLOAT64:
      convert(double{});
      break;
    default:
      BS_THROW(file << ": unsupported DICOM pixel format " << pf);
  }
  return s;
}

/// The DICOM files of `path`'s series: those of the folder, or of the file's series in its
/// folder. Sorted by name (positions decide the order later).
std::vector<std::string> series_files(const fs::path& path, DicomSeriesInfo* info) {
  const std::string where = path.string();
  std::error_code ec;
  BS_VERIFY(fs::exists(path, ec), where << ": no such file or folder");
  const bool folder = fs::is_directory(path, ec);
  const fs::path dir = folder                       ? path
                       : path.parent_path().empty() ? fs::path(".")
                                                    : path.parent_path();
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file()) files.push_back(entry.path().string());
  BS_VERIFY(!ec, where << ": cannot list the folder (" << ec.message() << ")");
  std::sort(files.begin(), files.end());
  const gdcm::Tag series_uid(0x0020, 0x000e);
  gdcm::Scanner scanner;
  scanner.AddTag(series_uid);
  BS_VERIFY(files.empty() || scanner.Scan(files), where << ": cannot scan the DICOM files");
  std::map<std::string, std::vector<std::string>> by_series;
  for (const std::string& f : files)
    if (scanner.IsKey(f.c_str())) {
      const char* uid = scanner.GetValue(f.c_str(), series_uid);
      std::string key = uid ? uid : "";
      while (!key.empty() && (key.back() == ' ' || key.back() == '\0')) key.pop_back();
      by_series[key].push_back(f);
    }
  BS_VERIFY(!by_series.empty(), where << ": no DICOM file found");
  std::string chosen;
  if (folder) {
    BS_VERIFY(by_series.size() == 1, where << ": the folder holds " << by_series.size()
                                           << " DICOM series; pass one file of the series wanted");
    chosen = by_series.begin()->first;
  } else {
    const std::string self = path.string();
    BS_VERIFY(
        scanner.IsKey(self.c_str()) || scanner.IsKey((dir / path.filename()).string().c_str()),
        where << ": not a DICOM file");
    const char* uid = scanner.GetValue((dir / path.filename()).string().c_str(), series_uid);
    chosen = uid ? uid : "";
    while (!chosen.empty() && (chosen.back() == ' ' || chosen.back() == '\0')) chosen.pop_back();
  }
  if (info) info->series_instance_uid = chosen;
  return by_series[chosen];
}

/// A DS value within DICOM's 16 characters, as precise as they allow.
std::string ds_value(double v) {
  if (std::abs(v) < 1e-12) v = 0.0;
  for (int precision = 15; precision > 0; --precision) {
    std::ostringstream o;
    o.precision(precision);
    o << v;
    if (o.str().size() <= 16) return o.str();
  }
  BS_THROW("a DICOM decimal string cannot hold " << v);
}

void put(gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element, gdcm::VR vr,
         std::string value) {
  if (value.size() % 2) value.push_back(vr == gdcm::VR::UI ? '\0' : ' ');
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), std::uint32_t(value.size()));
  ds.Replace(de);
}

void put_us(gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element, std::uint16_t value) {
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::US);
  const char bytes[2] = {char(value & 0xff), char(value >> 8)};  // little endian
  de.SetByteValue(bytes, 2);
  ds.Replace(de);
}

}  // namespace

bool is_dicom_path(const std::filesystem::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return true;
  const std::string ext = lower_case(path.extension().string());
  if (ext == ".dcm" || ext == ".ima") return true;
  if (!path.extension().empty()) return false;
  std::ifstream in(path, std::ios::binary);
  char magic[132] = {};
  return in.read(magic, 132) && std::memcmp(magic + 128, "DICM", 4) == 0;
}

VolumeF read_dicom_series(const std::filesystem::path& path, DicomSeriesInfo* info) {
  const std::string where = path.string();
  const std::vector<std::string> files = series_files(path, info);
  std::vector<Slice> slices;
  slices.reserve(files.size());
  for (const std::string& f : files)
    slices.push_back(read_slice(f, slices.empty() ? info : nullptr));

  const Slice& first = slices.front();
  const Vector3d row(first.orientation[0], first.orientation[1], first.orientation[2]);
  const Vector3d col(first.orientation[3], first.orientation[4], first.orientation[5]);
  BS_VERIFY(std::abs(row.norm() - 1) < 1e-3 && std::abs(col.norm() - 1) < 1e-3 &&
                std::abs(row.dot(col)) < 1e-3,
            first.file << ": DICOM Image Orientation (Patient) is not two orthonormal directions");
  const Vector3d normal = row.cross(col).normalized();
  for (const Slice& s : slices) {
    BS_VERIFY(s.columns == first.columns && s.rows == first.rows,
              where << ": the series mixes image sizes (" << s.file << ")");
    for (int a = 0; a < 6; ++a)
      BS_VERIFY(std::abs(s.orientation[std::size_t(a)] - first.orientation[std::size_t(a)]) < 1e-4,
                where << ": the series mixes orientations (" << s.file << ")");
    BS_VERIFY(std::abs(s.spacing_x - first.spacing_x) < 1e-4 &&
                  std::abs(s.spacing_y - first.spacing_y) < 1e-4,
              where << ": the series mixes pixel spacings (" << s.file << ")");
  }
  std::sort(slices.begin(), slices.end(), [&](const Slice& a, const Slice& b) {
    return a.position_lps.dot(normal) < b.position_lps.dot(normal);
  });
  double dz = slices.size() > 1 ? 0.0 : (first.thickness > 0 ? first.thickness : 1.0);
  if (slices.size() > 1) {
    const Vector3d span = slices.back().position_lps - slices.front().position_lps;
    dz = span.dot(normal) / double(slices.size() - 1);
    BS_VERIFY(dz > 1e-6, where << ": slices at one position (" << slices.front().file << ", "
                               << slices[1].file << ")");
    BS_VERIFY((span - span.dot(normal) * normal).norm() < 1e-3 * span.norm() + 1e-4,
              where << ": the slices do not stack along the image normal (gantry tilt?)");
    for (std::size_t k = 1; k < slices.size(); ++k) {
      const double gap = (slices[k].position_lps - slices[k - 1].position_lps).dot(normal);
      BS_VERIFY(std::abs(gap - dz) < 0.01 * dz + 1e-4,
                where << ": slices unevenly spaced (" << gap << " mm before " << slices[k].file
                      << ", " << dz << " mm on average): a slice is missing or duplicated");
    }
  }

  ImageGeometry g;
  g.size = Eigen::Vector3i(int(first.columns), int(first.rows), int(slices.size()));
  g.spacing = Vector3d(first.spacing_x, first.spacing_y, dz);
  const Vector3d to_ras(-1, -1, 1);
  g.origin = to_ras.cwiseProduct(slices.front().position_lps);
  g.direction.col(0) = to_ras.cwiseProduct(row.normalized());
  g.direction.col(1) = to_ras.cwiseProduct(col.normalized());
  g.direction.col(2) = to_ras.cwiseProduct(normal);
  orthonormalise_direction(g, where);
  verify_geometry(g, where);
  VolumeF volume(g, 1);
  const std::size_t per_slice = std::size_t(first.columns) * first.rows;
  for (std::size_t k = 0; k < slices.size(); ++k)
    std::copy(slices[k].values.begin(), slices[k].values.end(),
              volume.data.begin() + std::ptrdiff_t(k * per_slice));

  return volume;
}

void write_dicom_series(const std::filesystem::path& dir, const VolumeF& volume,
                        const DicomSeriesInfo& source, const std::string& description) {
  const std::string where = dir.string();
  BS_VERIFY(volume.components == 1, where
                                        << ": a DICOM MR series holds one component per voxel, got "
                                        << volume.components);
  BS_VERIFY(!volume.empty(), where << ": the volume to write as DICOM is empty");
  BS_VERIFY(
      description.size() <= 64,
      where << ": a DICOM Series Description holds 64 characters, got " << description.size());
  float lo = 0, hi = 0;
  bool integral = true;
  for (std::size_t i = 0; i < volume.data.size(); ++i) {
    const float v = volume.data[i];
    BS_VERIFY(std::isfinite(v), where << ": the volume has a non-finite value at voxel " << i);
    lo = i ? std::min(lo, v) : v;
    hi = i ? std::max(hi, v) : v;
    integral = integral && v == std::round(v);
  }
  // Stored values s ∈ int16: v = slope · s + intercept. Integer volumes in range are stored as
  // they are; others span the int16 range (error ≤ slope / 2).
  double slope = 1.0, intercept = 0.0;
  if (!(integral && lo >= -32768.0f && hi <= 32767.0f)) {
    slope = hi > lo ? (double(hi) - double(lo)) / 65535.0 : 1.0;
    intercept = double(lo) + 32768.0 * slope;
  }
  // The values as the file states them (a decimal string of ≤ 16 characters).
  slope = std::strtod(ds_value(slope).c_str(), nullptr);
  intercept = std::strtod(ds_value(intercept).c_str(), nullptr);

  const ImageGeometry& g = volume.geometry;
  const Vector3d to_lps(-1, -1, 1);
  const Vector3d origin = to_lps.cwiseProduct(g.origin);
  const Vector3d row = to_lps.cwiseProduct(Vector3d(g.direction.col(0)));
  const Vector3d col = to_lps.cwiseProduct(Vector3d(g.direction.col(1)));
  const Vector3d step = to_lps.cwiseProduct(Vector3d(g.direction.col(2))) * g.spacing[2];
  const Vector3d normal = row.cross(col);

  gdcm::UIDGenerator uids;
  const std::string study_uid =
      source.study_instance_uid.empty() ? uids.Generate() : source.study_instance_uid;
  const std::string series_uid = uids.Generate();
  const std::string frame_uid =
      source.frame_of_reference_uid.empty() ? uids.Generate() : source.frame_of_reference_uid;
  const std::string series_number = std::to_string(source.series_number + 1000);
  const auto ds_list = [](std::initializer_list<double> values) {
    std::string s;
    for (double v : values) {
      if (!s.empty()) s += '\\';  // appended, not "" + std::string&& (GCC 12's false -Wrestrict)
      s += ds_value(v);
    }
    return s;
  };
  const int nx = g.size[0], ny = g.size[1], nz = g.size[2];
  std::vector<std::int16_t> pixels(std::size_t(nx) * std::size_t(ny));
  for (int k = 0; k < nz; ++k) {
    const Vector3d position = origin + double(k) * step;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const double v = double(volume.at(i, j, k));
        const double s = std::round((v - intercept) / slope);
        pixels[std::size_t(j) * std::size_t(nx) + std::size_t(i)] =
            std::int16_t(std::clamp(s, -32768.0, 32767.0));
      }
    gdcm::Writer writer;
    gdcm::File& file = writer.GetFile();
    file.GetHeader().SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
    gdcm::DataSet& ds = file.GetDataSet();
    put(ds, 0x0008, 0x0008, gdcm::VR::CS, "DERIVED\\SECONDARY");
    put(ds, 0x0008, 0x0016, gdcm::VR::UI, "1.2.840.10008.5.1.4.1.1.4");  // MR Image Storage
    put(ds, 0x0008, 0x0018, gdcm::VR::UI, uids.Generate());
    put(ds, 0x0008, 0x0020, gdcm::VR::DA, source.study_date);
    put(ds, 0x0008, 0x0030, gdcm::VR::TM, source.study_time);
    put(ds, 0x0008, 0x0050, gdcm::VR::SH, source.accession_number);
    put(ds, 0x0008, 0x0060, gdcm::VR::CS, "MR");
    put(ds, 0x0008, 0x0070, gdcm::VR::LO, "brainshift");
    put(ds, 0x0008, 0x0090, gdcm::VR::PN, "");
    put(ds, 0x0008, 0x1030, gdcm::VR::LO, source.study_description);
    put(ds, 0x0008, 0x103e, gdcm::VR::LO, description);
    put(ds, 0x0008, 0x2111, gdcm::VR::ST,
        "Pre-operative MRI warped to the brain's intra-operative shape by brainshift "
        "(research software). Not for diagnosis.");
    put(ds, 0x0010, 0x0010, gdcm::VR::PN, source.patient_name);
    put(ds, 0x0010, 0x0020, gdcm::VR::LO, source.patient_id);
    put(ds, 0x0010, 0x0030, gdcm::VR::DA, source.patient_birth_date);
    put(ds, 0x0010, 0x0040, gdcm::VR::CS, source.patient_sex);
    put(ds, 0x0018, 0x0020, gdcm::VR::CS, "RM");  // research mode: no acquisition sequence
    put(ds, 0x0018, 0x0021, gdcm::VR::CS, "NONE");
    put(ds, 0x0018, 0x0022, gdcm::VR::CS, "");
    put(ds, 0x0018, 0x0023, gdcm::VR::CS, "3D");
    put(ds, 0x0018, 0x0050, gdcm::VR::DS, ds_value(g.spacing[2]));
    put(ds, 0x0018, 0x0088, gdcm::VR::DS, ds_value(g.spacing[2]));
    put(ds, 0x0018, 0x0080, gdcm::VR::DS, "");
    put(ds, 0x0018, 0x0081, gdcm::VR::DS, "");
    put(ds, 0x0018, 0x0091, gdcm::VR::IS, "");
    put(ds, 0x0020, 0x000d, gdcm::VR::UI, study_uid);
    put(ds, 0x0020, 0x000e, gdcm::VR::UI, series_uid);
    put(ds, 0x0020, 0x0010, gdcm::VR::SH, source.study_id);
    put(ds, 0x0020, 0x0011, gdcm::VR::IS, series_number);
    put(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(k + 1));
    put(ds, 0x0020, 0x0032, gdcm::VR::DS, ds_list({position[0], position[1], position[2]}));
    put(ds, 0x0020, 0x0037, gdcm::VR::DS,
        ds_list({row[0], row[1], row[2], col[0], col[1], col[2]}));
    put(ds, 0x0020, 0x0052, gdcm::VR::UI, frame_uid);
    put(ds, 0x0020, 0x1040, gdcm::VR::LO, "");
    put(ds, 0x0020, 0x1041, gdcm::VR::DS, ds_value(position.dot(normal)));
    put_us(ds, 0x0028, 0x0002, 1);
    put(ds, 0x0028, 0x0004, gdcm::VR::CS, "MONOCHROME2");
    put_us(ds, 0x0028, 0x0010, std::uint16_t(ny));
    put_us(ds, 0x0028, 0x0011, std::uint16_t(nx));
    // Pixel Spacing: between rows (along j), then between columns (along i).
    put(ds, 0x0028, 0x0030, gdcm::VR::DS, ds_list({g.spacing[1], g.spacing[0]}));
    put_us(ds, 0x0028, 0x0100, 16);
    put_us(ds, 0x0028, 0x0101, 16);
    put_us(ds, 0x0028, 0x0102, 15);
    put_us(ds, 0x0028, 0x0103, 1);
    put(ds, 0x0028, 0x1050, gdcm::VR::DS, ds_value(0.5 * (double(lo) + double(hi))));
    put(ds, 0x0028, 0x1051, gdcm::VR::DS, ds_value(std::max(1e-3, double(hi) - double(lo))));
    put(ds, 0x0028, 0x1052, gdcm::VR::DS, ds_value(intercept));
    put(ds, 0x0028, 0x1053, gdcm::VR::DS, ds_value(slope));
    put(ds, 0x0028, 0x1054, gdcm::VR::LO, "US");  // unspecified units
    gdcm::DataElement pixel_data(gdcm::Tag(0x7fe0, 0x0010));
    pixel_data.SetVR(gdcm::VR::OW);
    pixel_data.SetByteValue(reinterpret_cast<const char*>(pixels.data()),
                            std::uint32_t(pixels.size() * sizeof(std::int16_t)));
    ds.Replace(pixel_data);

    char name[32];
    std::snprintf(name, sizeof name, "IMG%04d.dcm", k + 1);
    const std::string target = (dir / name).string();
    writer.SetFileName(target.c_str());
    BS_VERIFY(writer.Write(), target << ": cannot write the DICOM file");
  }
}

}  // namespace brainshift::imaging
