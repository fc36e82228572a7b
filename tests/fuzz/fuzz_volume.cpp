// Every volume format that read_volume() takes from other programs (imaging/io/image_io.cpp):
// NIfTI-1 plain and gzip (our header check, then VTK's reader), MetaImage (.mha, with a PLUS-style
// header) and VTK XML image data (.vti). The first byte chooses the format; the rest is the file.
// NRRD has its own target (fuzz_nrrd).
#include "fuzz_input.hpp"

#include "imaging/io/image_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static const char* const names[] = {"input.nii", "input.nii.gz", "input.mha", "input.vti"};
  const auto file = brainshift::fuzz::as_file(data + 1, size - 1, names[data[0] % 4]);
  brainshift::fuzz::expect_refusal_or_success(
      [&] { (void)brainshift::imaging::read_volume(file); });
  return 0;
}
