// NRRD files (imaging/io/nrrd_io.cpp, our own parser): header fields, raw and gzip data.
#include "fuzz_input.hpp"

#include "imaging/io/nrrd_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = brainshift::fuzz::as_file(data, size, "input.nrrd");
  brainshift::fuzz::expect_refusal_or_success([&] { (void)brainshift::imaging::read_nrrd(file); });
  return 0;
}
