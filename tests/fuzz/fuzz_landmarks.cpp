// Landmark files (imaging/io/landmark_files.cpp, csv.cpp): MNI .tag, Slicer .fcsv and .mrk.json,
// CSV. The first byte chooses the format; the rest is the file.
#include "fuzz_input.hpp"

#include "imaging/io/landmark_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static const char* const names[] = {"input.tag", "input.fcsv", "input.mrk.json", "input.csv"};
  const auto file = brainshift::fuzz::as_file(data + 1, size - 1, names[data[0] % 4]);
  brainshift::fuzz::expect_refusal_or_success([&] {
    (void)brainshift::imaging::read_landmark_file(file, brainshift::imaging::TagVolume::FIRST);
  });
  return 0;
}
