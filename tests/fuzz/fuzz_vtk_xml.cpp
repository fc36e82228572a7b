// The VTK XML meshes and polylines brainshift reads (imaging/io: mesh_io, skeleton_io,
// surface_io; imaging/footprint/footprint_io): our header check, VTK's XML readers and our
// conversion of what they return. The first byte chooses the reader; the rest is the file.
#include "fuzz_input.hpp"

#include "imaging/footprint/footprint_io.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/io/surface_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  namespace im = brainshift::imaging;
  const int reader = data[0] % 5;
  const auto file =
      brainshift::fuzz::as_file(data + 1, size - 1, reader < 2 ? "input.vtu" : "input.vtp");
  brainshift::fuzz::expect_refusal_or_success([&] {
    switch (reader) {
      case 0:
        (void)im::read_tet_mesh(file);
        break;
      case 1:
        (void)im::read_displacement(file);
        break;
      case 2:
        (void)im::read_skeleton_vtp(file);
        break;
      case 3:
        (void)im::read_surface_vtp(file);
        break;
      default:
        (void)im::read_footprint_vtp(file);
        break;
    }
  });
  return 0;
}
