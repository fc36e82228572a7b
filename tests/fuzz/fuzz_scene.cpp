// Scene files (apps/workflow/scene_io.cpp): the first byte chooses between read_scene() — the
// JSON, its options and the files it names, beside it a valid one-tetrahedron mesh.vtu and
// fixed.csv so that a fuzzed scene can reach the option parsing — and check_scene_options(), the
// overrides `prepare --scene-options` takes.
#include "fuzz_input.hpp"

#include "apps/workflow/scene_io.hpp"

#include <string>

namespace {

const std::string mesh =
    "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
    "<UnstructuredGrid><Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n<Points><DataArray "
    "type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 10 0 0 0 10 0 0 0 10"
    "</DataArray></Points>\n<Cells><DataArray type=\"Int64\" Name=\"connectivity\" "
    "format=\"ascii\">0 1 2 3</DataArray><DataArray type=\"Int64\" Name=\"offsets\" "
    "format=\"ascii\">4</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10"
    "</DataArray></Cells>\n</Piece></UnstructuredGrid></VTKFile>\n";
const std::string fixed = "node\n0\n1\n2\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  using brainshift::fuzz::as_file;
  static const bool written = [] {
    as_file(reinterpret_cast<const std::uint8_t*>(mesh.data()), mesh.size(), "mesh.vtu");
    as_file(reinterpret_cast<const std::uint8_t*>(fixed.data()), fixed.size(), "fixed.csv");
    return true;
  }();
  (void)written;
  if (data[0] % 2 == 0) {
    const auto file = as_file(data + 1, size - 1, "scene.json");
    brainshift::fuzz::expect_refusal_or_success(
        [&] { (void)brainshift::workflow::read_scene(file); });
  } else {
    const auto file = as_file(data + 1, size - 1, "options.json");
    brainshift::fuzz::expect_refusal_or_success(
        [&] { brainshift::workflow::check_scene_options(file); });
  }
  return 0;
}
