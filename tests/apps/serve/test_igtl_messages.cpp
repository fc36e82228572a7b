// OpenIGTLink IMAGE ↔ volume (apps/serve/igtl_messages.hpp): the geometry convention (position =
// the image centre), LPS images, the sender's byte order, and the refusals. The wire format itself
// is checked against an independent client in tests/apps/test_serve.cpp.

#include "tests/config.hpp"

#include "apps/serve/igtl_messages.hpp"
#include "core/error.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <igtlMessageHeader.h>

namespace brainshift::serve {
namespace {

/// A small oblique volume with distinct voxel values.
imaging::VolumeF oblique_volume() {
  imaging::ImageGeometry g;
  g.size = Eigen::Vector3i(5, 4, 3);
  g.spacing = Vector3d(0.5, 0.75, 1.25);
  g.origin = Vector3d(-20.25, 13.5, 40.0);
  g.direction = Eigen::AngleAxisd(0.3, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  imaging::VolumeF v(g, 1);
  for (std::size_t i = 0; i < v.data.size(); ++i) v.data[i] = float(i) * 1.5f - 7.0f;
  return v;
}

/// What a receiver sees of a packed message: its header and body unpacked as a new message.
igtl::ImageMessage::Pointer receive(igtl::ImageMessage::Pointer sent) {
  auto header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), sent->GetPackPointer(), header->GetPackSize());
  header->Unpack();
  auto m = igtl::ImageMessage::New();
  m->SetMessageHeader(header);
  m->AllocatePack();
  std::memcpy(m->GetPackBodyPointer(), sent->GetPackBodyPointer(), sent->GetPackBodySize());
  EXPECT_TRUE(m->Unpack(1) & igtl::MessageHeader::UNPACK_BODY);
  return m;
}

TEST(IgtlMessages, AVolumeTravelsWithItsGeometryAndVoxels) {
  const imaging::VolumeF v = oblique_volume();
  auto sent = image_message(v, "Doppler");
  auto got = receive(sent);
  // The position field is the centre of the voxel centres: origin + D·diag(s)·(n − 1)/2.
  float p[3];
  got->GetOrigin(p);
  const Vector3d centre = v.geometry.index_to_world(Vector3d(2.0, 1.5, 1.0));
  EXPECT_LT((Vector3d(p[0], p[1], p[2]) - centre).norm(), 1e-4);
  const imaging::VolumeF back =
      volume_from_image(*got, std::uint64_t(sent->GetPackBodySize()), "D");
  // float32 in the message: positions to 1e-5 mm at |x| ≈ 40 mm (bar 1e-4), directions to 1e-6.
  EXPECT_LT((back.geometry.origin - v.geometry.origin).norm(), 1e-4);
  EXPECT_LT((back.geometry.spacing - v.geometry.spacing).norm(), 1e-6);
  EXPECT_LT((back.geometry.direction - v.geometry.direction).norm(), 1e-6);
  EXPECT_EQ(back.data, v.data);
}

TEST(IgtlMessages, LpsImagesAndBigEndianVoxelsAreConverted) {
  const imaging::VolumeF v = oblique_volume();
  auto m = image_message(v, "Doppler");
  // The same image as an LPS sender would describe it, voxels as big-endian int16.
  Eigen::Matrix3d d_lps = v.geometry.direction;
  d_lps.row(0) *= -1.0;
  d_lps.row(1) *= -1.0;
  const Vector3d c = v.geometry.index_to_world(Vector3d(2.0, 1.5, 1.0));
  auto lps = igtl::ImageMessage::New();
  lps->SetDeviceName("Doppler");
  lps->SetDimensions(5, 4, 3);
  lps->SetSpacing(0.5f, 0.75f, 1.25f);
  lps->SetScalarType(igtl::ImageMessage::TYPE_INT16);
  lps->SetEndian(igtl::ImageMessage::ENDIAN_BIG);
  lps->SetCoordinateSystem(igtl::ImageMessage::COORDINATE_LPS);
  igtl::Matrix4x4 mat;
  igtl::IdentityMatrix(mat);
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) mat[r][k] = float(d_lps(r, k));
    mat[r][3] = float(r < 2 ? -c[r] : c[r]);
  }
  lps->SetMatrix(mat);
  lps->AllocateScalars();
  auto* bytes = static_cast<unsigned char*>(lps->GetScalarPointer());
  for (int i = 0; i < 60; ++i) {
    const std::int16_t value = std::int16_t(i * 3 - 100);
    bytes[2 * i] = std::uint8_t((std::uint16_t(value) >> 8) & 0xff);
    bytes[2 * i + 1] = std::uint8_t(std::uint16_t(value) & 0xff);
  }
  lps->Pack();
  auto got = receive(lps);
  const imaging::VolumeF back = volume_from_image(*got, std::uint64_t(lps->GetPackBodySize()), "D");
  EXPECT_LT((back.geometry.origin - v.geometry.origin).norm(), 1e-4);
  EXPECT_LT((back.geometry.direction - v.geometry.direction).norm(), 1e-6);
  for (int i = 0; i < 60; ++i) EXPECT_EQ(back.data[std::size_t(i)], float(i * 3 - 100)) << i;
}

TEST(IgtlMessages, AVectorImageAndAWrongBodySizeAreRefusedByName) {
  const imaging::VolumeF v = oblique_volume();
  auto sent = image_message(v, "Doppler");
  auto got = receive(sent);
  try {
    (void)volume_from_image(*got, std::uint64_t(sent->GetPackBodySize()) - 4, "Doppler #9");
    FAIL() << "a body 4 bytes short was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("Doppler #9"), std::string::npos) << e.what();
  }
  got->SetNumComponents(3);
  EXPECT_THROW((void)volume_from_image(*got, std::uint64_t(sent->GetPackBodySize()), "D"), Error);
}

TEST(IgtlMessagesReal, RealIntraoperativeVolumesTravelWithTheirGeometry) {
  // RESECT's real B-mode volumes (oblique, as the tracker placed them; read by VTK's NIfTI
  // reader): through an IMAGE message and back, voxels exactly and the grid to float32 rounding
  // (|x| ≤ 200 mm: 2e-5 mm; bar 1e-4 mm). Three cases keep the test short.
  const std::filesystem::path folder = std::filesystem::path(tests::shared_data_dir) / "resect";
  if (!std::filesystem::exists(folder))
    GTEST_SKIP() << "real data absent: " << folder << " (RESECT B-mode volumes)";
  for (const char* name : {"Case1.nii.gz", "Case12.nii.gz", "Case27.nii.gz"}) {
    const imaging::VolumeF v = imaging::read_volume(folder / name);
    auto sent = image_message(v, "BMode");
    auto got = receive(sent);
    const imaging::VolumeF back =
        volume_from_image(*got, std::uint64_t(sent->GetPackBodySize()), name);
    EXPECT_EQ(back.geometry.size, v.geometry.size) << name;
    EXPECT_LT((back.geometry.origin - v.geometry.origin).norm(), 1e-4) << name;
    EXPECT_LT((back.geometry.spacing - v.geometry.spacing).norm(), 1e-6) << name;
    EXPECT_LT((back.geometry.direction - v.geometry.direction).norm(), 1e-6) << name;
    EXPECT_TRUE(back.data == v.data) << name;
  }
}

TEST(IgtlMessages, PolylinesJoinConsecutiveSegments) {
  MatrixX3d p(5, 3);
  p << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 0, 2, 0;
  // 0-1-2 is one line; 3-4 another.
  auto m = lines_message(p, {{0, 1}, {1, 2}, {3, 4}}, "DeformedVessels");
  EXPECT_EQ(m->GetLines()->GetNumberOfCells(), 2u);
  EXPECT_EQ(m->GetLines()->GetCellSize(0), 3u);
  EXPECT_EQ(m->GetPoints()->GetNumberOfPoints(), 5);
  EXPECT_THROW((void)lines_message(p, {{0, 7}}, "X"), Error);
}

}  // namespace
}  // namespace brainshift::serve
