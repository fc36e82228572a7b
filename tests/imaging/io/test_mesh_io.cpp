#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "core/error.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/io/mesh_io.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

namespace brainshift::imaging {
namespace {

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

/// A hand-written ASCII .vtu with 4 nodes and one cell of VTK type `type`, and `cell_data`
/// (XML of <CellData> content) verbatim.
std::string one_cell_vtu(int type, const std::string& cell_data = "") {
  return R"(<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
  <UnstructuredGrid>
    <Piece NumberOfPoints="4" NumberOfCells="1">
      <Points>
        <DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1</DataArray>
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">)" +
         std::to_string(type) + R"(</DataArray>
      </Cells>
      <CellData>)" +
         cell_data + R"(</CellData>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
)";
}

using tests::expect_error;

TEST(MeshIo, RoundTripIsExact) {
  const tests::TempFolder dir;
  const core::TetMesh box = data_synth::make_box_mesh({10, 20, 30}, {3, 4, 5}, {-3.1, 0.7, 1e-3});
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd E(box.num_tets()), nu(box.num_tets());
  for (index_t t = 0; t < box.num_tets(); ++t) {
    E(t) = 1.5 + 8.5 * (u(rng) + 1.0) / 2.0;  // kPa, brain to tumour
    nu(t) = 0.45 + 0.04 * u(rng);
  }
  const core::TetMesh mesh(box.nodes(), box.tets(), E, nu);
  MatrixX3d displacement(mesh.num_nodes(), 3);
  for (Eigen::Index i = 0; i < displacement.size(); ++i) displacement.data()[i] = u(rng) / 3.0;

  const auto path = dir / "mesh.vtu";
  write_tet_mesh(path, mesh, &displacement);
  EXPECT_EQ(dir.count(), 1u) << "temporary file left behind";
  const core::TetMesh back = read_tet_mesh(path);
  // Binary appended data: bit-exact.
  EXPECT_EQ(back.nodes(), mesh.nodes());
  EXPECT_EQ(back.tets(), mesh.tets());
  EXPECT_EQ(back.youngs_modulus(), mesh.youngs_modulus());
  EXPECT_EQ(back.poisson_ratio(), mesh.poisson_ratio());
  EXPECT_EQ(read_displacement(path), displacement);
}

TEST(MeshIo, OverwritingReplacesTheFileAndLeavesNoTemporary) {
  const tests::TempFolder dir;
  const auto path = dir / "mesh.vtu";
  write_tet_mesh(path, data_synth::make_box_mesh({1, 1, 1}, {1, 1, 1}));
  const core::TetMesh bigger = data_synth::make_box_mesh({1, 1, 1}, {2, 2, 2});
  write_tet_mesh(path, bigger);
  EXPECT_EQ(read_tet_mesh(path).num_tets(), bigger.num_tets());
  EXPECT_EQ(dir.count(), 1u);
  expect_error([&] { (void)read_displacement(path); }, {path.string(), "displacement"});
}

TEST(MeshIo, MissingMaterialArraysDefaultToBrain) {
  const tests::TempFolder dir;
  const auto path = dir / "plain.vtu";
  write_text(path, one_cell_vtu(/*VTK_TETRA=*/10));
  const core::TetMesh mesh = read_tet_mesh(path);
  ASSERT_EQ(mesh.num_tets(), 1);
  EXPECT_EQ(mesh.nodes().row(3), Eigen::RowVector3d(0, 0, 1));
  EXPECT_EQ(mesh.youngs_modulus()(0), 1.5);
  EXPECT_EQ(mesh.poisson_ratio()(0), 0.45);

  write_text(
      path,
      one_cell_vtu(
          10, R"(<DataArray type="Float64" Name="youngs_modulus" format="ascii">10</DataArray>)"));
  const core::TetMesh tumour = read_tet_mesh(path);
  EXPECT_EQ(tumour.youngs_modulus()(0), 10.0);
  EXPECT_EQ(tumour.poisson_ratio()(0), 0.45);
}

TEST(MeshIo, MissingFileIsNamed) {
  const tests::TempFolder dir;
  expect_error([&] { (void)read_tet_mesh(dir / "nope.vtu"); }, {"nope.vtu", "no such file"});
}

TEST(MeshIo, NonXmlFileIsNamed) {
  const tests::TempFolder dir;
  const auto path = dir / "junk.vtu";
  write_text(path, "this is not XML\n1 2 3\n");
  expect_error([&] { (void)read_tet_mesh(path); }, {path.string(), "not a VTK XML"});
}

TEST(MeshIo, TruncatedFileIsNamed) {
  const tests::TempFolder dir;
  const auto path = dir / "cut.vtu";
  write_text(path, one_cell_vtu(10).substr(0, 400));
  expect_error([&] { (void)read_tet_mesh(path); }, {path.string(), "cannot read"});
}

TEST(MeshIo, WrongCellTypeIsNamed) {
  const tests::TempFolder dir;
  const auto path = dir / "quad.vtu";
  write_text(path, one_cell_vtu(/*VTK_QUAD=*/9));
  expect_error([&] { (void)read_tet_mesh(path); },
               {path.string(), "cell 0", "vtkQuad", "tetrahedra"});
}

TEST(MeshIo, NaNCoordinateIsNamed) {
  const tests::TempFolder dir;
  const core::TetMesh box = data_synth::make_box_mesh({1, 1, 1}, {1, 1, 1});
  MatrixX3d X = box.nodes();
  X(2, 1) = std::numeric_limits<double>::quiet_NaN();
  const auto path = dir / "nan.vtu";
  write_tet_mesh(path, core::TetMesh(X, box.tets()));
  expect_error([&] { (void)read_tet_mesh(path); }, {path.string(), "NaN"});
}

TEST(MeshIo, InvertedTetrahedronIsNamed) {
  const tests::TempFolder dir;
  const core::TetMesh box = data_synth::make_box_mesh({1, 1, 1}, {1, 1, 1});
  MatrixX4i T = box.tets();
  std::swap(T(4, 1), T(4, 2));
  const auto path = dir / "inverted.vtu";
  write_tet_mesh(path, core::TetMesh(box.nodes(), T));
  expect_error([&] { (void)read_tet_mesh(path); }, {path.string(), "tetrahedron 4"});
}

TEST(MeshIo, UnwritableFolderIsNamedAndNothingIsLeft) {
  const tests::TempFolder dir;
  const core::TetMesh box = data_synth::make_box_mesh({1, 1, 1}, {1, 1, 1});
  const auto missing = dir / "no_such_folder" / "out.vtu";
  expect_error([&] { write_tet_mesh(missing, box); }, {missing.string(), "does not exist"});
  write_text(dir / "file", "x");
  const auto under_file = dir / "file" / "out.vtu";
  expect_error([&] { write_tet_mesh(under_file, box); }, {under_file.string(), "not a folder"});
  EXPECT_EQ(dir.count(), 1u);
  // A folder nobody may create files in, even root: /proc.
  if (std::filesystem::is_directory("/proc")) {
    expect_error([&] { write_tet_mesh("/proc/out.vtu", box); }, {"/proc/out.vtu"});
  }
}

TEST(MeshIo, DisplacementWithWrongRowCountIsRejected) {
  const tests::TempFolder dir;
  const core::TetMesh box = data_synth::make_box_mesh({1, 1, 1}, {1, 1, 1});
  const MatrixX3d u = MatrixX3d::Zero(3, 3);
  expect_error([&] { write_tet_mesh(dir / "m.vtu", box, &u); }, {"m.vtu", "3 rows"});
  EXPECT_EQ(dir.count(), 0u);
}

}  // namespace
}  // namespace brainshift::imaging
