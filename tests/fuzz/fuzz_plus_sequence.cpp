// PLUS sequence files (imaging/io/plus_sequence.cpp, our own parser): .seq.mha headers with
// per-frame transforms, raw or zlib data.
#include "fuzz_input.hpp"

#include "imaging/io/plus_sequence.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = brainshift::fuzz::as_file(data, size, "input.seq.mha");
  brainshift::fuzz::expect_refusal_or_success(
      [&] { (void)brainshift::imaging::read_plus_sequence(file); });
  return 0;
}
