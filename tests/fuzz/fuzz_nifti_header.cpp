// The NIfTI-1 header check (imaging/io/header_checks.cpp) that runs before VTK reads a file:
// plain and gzip-compressed.
#include "fuzz_input.hpp"

#include "imaging/io/header_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = brainshift::fuzz::as_file(data, size, "input.nii");
  brainshift::fuzz::expect_refusal_or_success(
      [&] { brainshift::imaging::verify_nifti_header(file.string()); });
  return 0;
}
