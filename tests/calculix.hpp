#pragma once
/// @file
/// @brief Driving CalculiX (`ccx`, Debian package calculix-ccx) from the reference tests: is it on
/// PATH, the mesh and node-set cards of an input deck, running a deck in a folder and reading the
/// nodal displacements it prints to the .dat file. Lengths in mm, node numbers 1-based in the
/// deck (our index + 1). Used by tests/core/test_calculix.cpp and
/// tests/data_synth/truth/test_tled_calculix.cpp.

#include "tolerance.hpp"

#include "core/config.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <limits>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace brainshift::tests::calculix {

/// True when `ccx` is on PATH (tests GTEST_SKIP otherwise).
inline bool ccx_available() { return std::system("command -v ccx > /dev/null 2>&1") == 0; }

/// `*NODE, NSET=NALL` and `*ELEMENT, TYPE=C3D4, ELSET=EALL` cards of a mesh (full precision).
/// Our positive orientation is the Abaqus/ccx one: node 4 on the side of face 1-2-3 given by the
/// right-hand rule.
inline void write_mesh(std::ostream& out, const core::TetMesh& m) {
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  out << "*NODE, NSET=NALL\n";
  for (index_t i = 0; i < m.num_nodes(); ++i)
    out << i + 1 << ", " << m.nodes()(i, 0) << ", " << m.nodes()(i, 1) << ", " << m.nodes()(i, 2)
        << "\n";
  out << "*ELEMENT, TYPE=C3D4, ELSET=EALL\n";
  for (index_t t = 0; t < m.num_tets(); ++t)
    out << t + 1 << ", " << m.tets()(t, 0) + 1 << ", " << m.tets()(t, 1) + 1 << ", "
        << m.tets()(t, 2) + 1 << ", " << m.tets()(t, 3) + 1 << "\n";
}

/// `*NSET, NSET=name` card listing `nodes` (our 0-based indices).
inline void write_node_set(std::ostream& out, const std::string& name,
                           const std::vector<index_t>& nodes) {
  out << "*NSET, NSET=" << name << "\n";
  for (std::size_t k = 0; k < nodes.size(); ++k)
    out << nodes[k] + 1 << ((k % 10 == 9 || k + 1 == nodes.size()) ? "\n" : ", ");
}

/// Displacements of the last "displacements (vx,vy,vz)" block of a ccx .dat file (#N×3, mm;
/// rows of nodes beyond num_nodes, e.g. auxiliary ground nodes, are ignored); `time` receives
/// that block's step time.
inline MatrixX3d read_dat_displacements(const std::filesystem::path& file, index_t num_nodes,
                                        double& time) {
  std::ifstream in(file);
  MatrixX3d u = MatrixX3d::Constant(num_nodes, 3, std::numeric_limits<double>::quiet_NaN());
  time = std::numeric_limits<double>::quiet_NaN();
  bool found = false, in_block = false;
  std::string line;
  while (std::getline(in, line)) {
    if (line.find("displacements (vx,vy,vz)") != std::string::npos) {
      found = in_block = true;
      const auto pos = line.find("time");
      time = pos == std::string::npos ? time : std::stod(line.substr(pos + 4));
      u.setConstant(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    if (!in_block) continue;
    std::istringstream row(line);
    long node = 0;
    double x = 0, y = 0, z = 0;
    if (!(row >> node >> x >> y >> z)) {
      if (line.find_first_not_of(" \t\r") != std::string::npos) in_block = false;  // next header
      continue;
    }
    if (node >= 1 && node <= num_nodes) u.row(node - 1) << x, y, z;
  }
  EXPECT_TRUE(found) << "no displacement block in " << file;
  return u;
}

/// Runs ccx on `deck` (without extension) in `folder`, one thread, output to ccx_<deck>.log;
/// returns the displacements of the first num_nodes nodes at the last printed increment and
/// checks that ccx succeeded and ended at step time 1. `seconds`: ccx's wall time.
inline MatrixX3d run_ccx(const std::filesystem::path& folder, const std::string& deck,
                         index_t num_nodes, double& seconds) {
  const std::string command = "cd '" + folder.string() + "' && OMP_NUM_THREADS=1 ccx -i " + deck +
                              " > ccx_" + deck + ".log 2>&1";
  const auto start = std::chrono::steady_clock::now();
  const int rc = std::system(command.c_str());
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::ifstream log(folder / ("ccx_" + deck + ".log"));
  const std::string log_text((std::istreambuf_iterator<char>(log)),
                             std::istreambuf_iterator<char>());
  EXPECT_EQ(rc, 0) << "ccx failed:\n" << log_text;
  EXPECT_EQ(log_text.find("*ERROR"), std::string::npos) << log_text;
  double time = 0;
  MatrixX3d u = read_dat_displacements(folder / (deck + ".dat"), num_nodes, time);
  EXPECT_TRUE(tests::near(time, 1.0, 1e-9, 0.0)) << "ccx did not reach the end of the step";
  EXPECT_TRUE(u.allFinite()) << "ccx printed no displacement for some nodes";
  return u;
}

/// max_i ‖a_i − b_i‖ over the rows, mm.
inline double max_nodal_difference(const MatrixX3d& a, const MatrixX3d& b) {
  return (a - b).rowwise().norm().maxCoeff();
}

}  // namespace brainshift::tests::calculix
