#include "apps/serve/igtl_messages.hpp"

#include "core/error.hpp"
#include "imaging/io/image_frame.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace brainshift::serve {
namespace {

/// Bytes of one value of an IMAGE scalar type, 0 for a type brainshift does not read.
int scalar_bytes(int type) {
  switch (type) {
    case igtl::ImageMessage::TYPE_INT8:
    case igtl::ImageMessage::TYPE_UINT8:
      return 1;
    case igtl::ImageMessage::TYPE_INT16:
    case igtl::ImageMessage::TYPE_UINT16:
      return 2;
    case igtl::ImageMessage::TYPE_INT32:
    case igtl::ImageMessage::TYPE_UINT32:
    case igtl::ImageMessage::TYPE_FLOAT32:
      return 4;
    case igtl::ImageMessage::TYPE_FLOAT64:
      return 8;
    default:
      return 0;
  }
}

/// Value `i` of raw voxel data of `type`, in the sender's byte order (`swap` when it is not ours).
template <typename T>
float value_at(const unsigned char* data, std::size_t i, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, data + i * sizeof(T), sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return static_cast<float>(v);
}

template <typename T>
void convert(const unsigned char* data, bool swap, std::vector<float>& out) {
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = value_at<T>(data, i, swap);
}

void to_floats(int type, const unsigned char* data, bool swap, std::vector<float>& out) {
  switch (type) {
    case igtl::ImageMessage::TYPE_INT8:
      return convert<std::int8_t>(data, swap, out);
    case igtl::ImageMessage::TYPE_UINT8:
      return convert<std::uint8_t>(data, swap, out);
    case igtl::ImageMessage::TYPE_INT16:
      return convert<std::int16_t>(data, swap, out);
    case igtl::ImageMessage::TYPE_UINT16:
      return convert<std::uint16_t>(data, swap, out);
    case igtl::ImageMessage::TYPE_INT32:
      return convert<std::int32_t>(data, swap, out);
    case igtl::ImageMessage::TYPE_UINT32:
      return convert<std::uint32_t>(data, swap, out);
    case igtl::ImageMessage::TYPE_FLOAT32:
      return convert<float>(data, swap, out);
    case igtl::ImageMessage::TYPE_FLOAT64:
      return convert<double>(data, swap, out);
    default:
      BS_THROW("scalar type " << type << " is not readable");
  }
}

}  // namespace

imaging::VolumeF volume_from_image(igtl::ImageMessage& m, std::uint64_t body_bytes,
                                   const std::string& name) {
  BS_VERIFY(m.GetNumComponents() == 1, name << ": IMAGE with " << m.GetNumComponents()
                                            << " components; expected a scalar image");
  const int type = m.GetScalarType();
  const int bytes = scalar_bytes(type);
  BS_VERIFY(bytes > 0,
            name << ": IMAGE scalar type " << type
                 << " is not one of OpenIGTLink's (2-7 integers, 10 float32, 11 float64)");
  int size[3], sub[3], offset[3];
  m.GetDimensions(size);
  m.GetSubVolume(sub, offset);
  BS_VERIFY(size[0] > 0 && size[1] > 0 && size[2] > 0,
            name << ": IMAGE of " << size[0] << "x" << size[1] << "x" << size[2] << " voxels");
  BS_VERIFY(sub[0] == size[0] && sub[1] == size[1] && sub[2] == size[2] && offset[0] == 0 &&
                offset[1] == 0 && offset[2] == 0,
            name << ": a partial IMAGE (sub-volume " << sub[0] << "x" << sub[1] << "x" << sub[2]
                 << " of " << size[0] << "x" << size[1] << "x" << size[2]
                 << "); send the whole volume");
  const std::uint64_t voxels = std::uint64_t(size[0]) * std::uint64_t(size[1]) * size[2];
  BS_VERIFY(body_bytes == image_header_bytes + voxels * std::uint64_t(bytes),
            name << ": IMAGE body of " << body_bytes << " bytes, but " << size[0] << "x" << size[1]
                 << "x" << size[2] << " voxels of " << bytes << " byte(s) need "
                 << image_header_bytes + voxels * std::uint64_t(bytes));
  const int endian = m.GetEndian();
  BS_VERIFY(endian == igtl::ImageMessage::ENDIAN_BIG || endian == igtl::ImageMessage::ENDIAN_LITTLE,
            name << ": IMAGE endian field " << endian << " (1 big, 2 little)");
  const int frame = m.GetCoordinateSystem();
  BS_VERIFY(
      frame == igtl::ImageMessage::COORDINATE_RAS || frame == igtl::ImageMessage::COORDINATE_LPS,
      name << ": IMAGE coordinate field " << frame << " (1 RAS, 2 LPS)");

  float spacing[3];
  m.GetSpacing(spacing);
  igtl::Matrix4x4 matrix;
  m.GetMatrix(matrix);
  imaging::ImageGeometry g;
  g.size = Eigen::Vector3i(size[0], size[1], size[2]);
  Vector3d centre;
  for (int r = 0; r < 3; ++r) {
    g.spacing[r] = spacing[r];
    centre[r] = matrix[r][3];
    for (int c = 0; c < 3; ++c) g.direction(r, c) = matrix[r][c];
  }
  if (frame == igtl::ImageMessage::COORDINATE_LPS) {
    g.direction.row(0) *= -1.0;
    g.direction.row(1) *= -1.0;
    centre.head<2>() *= -1.0;
  }
  // The matrix must be a rotation (or reflection) times the spacing: the same checks as a file's.
  g.origin = Vector3d::Zero();
  imaging::verify_geometry(g, name + ": IMAGE matrix");
  BS_VERIFY(centre.allFinite(), name << ": IMAGE position is not finite");
  imaging::orthonormalise_direction(g, name);
  const Vector3d half = (g.size.cast<double>() - Vector3d::Ones()) / 2.0;
  g.origin = centre - g.direction * g.spacing.cwiseProduct(half);

  imaging::VolumeF v(g, 1);
  const bool little_here = std::endian::native == std::endian::little;
  const bool swap = (endian == igtl::ImageMessage::ENDIAN_LITTLE) != little_here;
  to_floats(type, static_cast<const unsigned char*>(m.GetScalarPointer()), swap, v.data);
  return v;
}

igtl::ImageMessage::Pointer image_message(const imaging::VolumeF& v, const std::string& device) {
  BS_VERIFY(v.components == 1, device << ": only scalar volumes are sent as IMAGE");
  const imaging::ImageGeometry& g = v.geometry;
  for (int a = 0; a < 3; ++a)
    BS_VERIFY(g.size[a] > 0 && g.size[a] <= 65535,
              device << ": " << g.size[a] << " voxels along an axis (OpenIGTLink allows 1-65535)");
  auto m = igtl::ImageMessage::New();
  m->SetDeviceName(device.c_str());
  m->SetDimensions(g.size[0], g.size[1], g.size[2]);
  m->SetSpacing(float(g.spacing[0]), float(g.spacing[1]), float(g.spacing[2]));
  m->SetScalarType(igtl::ImageMessage::TYPE_FLOAT32);
  m->SetEndian(std::endian::native == std::endian::little ? igtl::ImageMessage::ENDIAN_LITTLE
                                                          : igtl::ImageMessage::ENDIAN_BIG);
  m->SetCoordinateSystem(igtl::ImageMessage::COORDINATE_RAS);
  const Vector3d half = (g.size.cast<double>() - Vector3d::Ones()) / 2.0;
  const Vector3d centre = g.origin + g.direction * g.spacing.cwiseProduct(half);
  igtl::Matrix4x4 matrix;
  igtl::IdentityMatrix(matrix);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) matrix[r][c] = float(g.direction(r, c));
    matrix[r][3] = float(centre[r]);
  }
  m->SetMatrix(matrix);
  m->AllocateScalars();
  std::memcpy(m->GetScalarPointer(), v.data.data(), v.data.size() * sizeof(float));
  m->Pack();
  return m;
}

igtl::TransformMessage::Pointer transform_message(const Eigen::Isometry3d& t,
                                                  const std::string& device) {
  auto m = igtl::TransformMessage::New();
  m->SetDeviceName(device.c_str());
  igtl::Matrix4x4 matrix;
  igtl::IdentityMatrix(matrix);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) matrix[r][c] = float(t.matrix()(r, c));
  m->SetMatrix(matrix);
  m->Pack();
  return m;
}

igtl::StatusMessage::Pointer status_message(int code, long long subcode,
                                            const std::string& error_name, const std::string& text,
                                            const std::string& device) {
  auto m = igtl::StatusMessage::New();
  m->SetDeviceName(device.c_str());
  m->SetCode(code);
  m->SetSubCode(subcode);
  m->SetErrorName(error_name.substr(0, 19).c_str());
  m->SetStatusString(text.c_str());
  m->Pack();
  return m;
}

igtl::StringMessage::Pointer string_message(const std::string& text, const std::string& device) {
  auto m = igtl::StringMessage::New();
  m->SetDeviceName(device.c_str());
  m->SetEncoding(106);  // IANA MIBenum of UTF-8
  m->SetString(text.c_str());
  m->Pack();
  return m;
}

namespace {

igtl::PolyDataPointArray::Pointer point_array(const MatrixX3d& points) {
  auto a = igtl::PolyDataPointArray::New();
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    a->AddPoint(float(points(i, 0)), float(points(i, 1)), float(points(i, 2)));
  return a;
}

}  // namespace

igtl::PolyDataMessage::Pointer lines_message(const MatrixX3d& points,
                                             const std::vector<std::array<index_t, 2>>& segments,
                                             const std::string& device) {
  auto m = igtl::PolyDataMessage::New();
  m->SetDeviceName(device.c_str());
  m->SetPoints(point_array(points));
  // Chains of segments become polylines: a segment continues the current line when it starts
  // where the line ends.
  auto lines = igtl::PolyDataCellArray::New();
  std::vector<igtlUint32> line;
  auto flush = [&] {
    if (line.size() >= 2) lines->AddCell(int(line.size()), line.data());
    line.clear();
  };
  for (const auto& s : segments) {
    BS_VERIFY(
        s[0] >= 0 && s[1] >= 0 && s[0] < points.rows() && s[1] < points.rows(),
        device << ": a segment names point " << std::max(s[0], s[1]) << " of " << points.rows());
    if (line.empty() || line.back() != igtlUint32(s[0])) {
      flush();
      line.push_back(igtlUint32(s[0]));
    }
    line.push_back(igtlUint32(s[1]));
  }
  flush();
  m->SetLines(lines);
  m->Pack();
  return m;
}

igtl::PolyDataMessage::Pointer surface_message(
    const MatrixX3d& points, const Eigen::Matrix<index_t, Eigen::Dynamic, 3, Eigen::RowMajor>& tri,
    const std::string& device) {
  auto m = igtl::PolyDataMessage::New();
  m->SetDeviceName(device.c_str());
  m->SetPoints(point_array(points));
  auto polygons = igtl::PolyDataCellArray::New();
  for (Eigen::Index f = 0; f < tri.rows(); ++f) {
    igtlUint32 cell[3] = {igtlUint32(tri(f, 0)), igtlUint32(tri(f, 1)), igtlUint32(tri(f, 2))};
    polygons->AddCell(3, cell);
  }
  m->SetPolygons(polygons);
  m->Pack();
  return m;
}

}  // namespace brainshift::serve
