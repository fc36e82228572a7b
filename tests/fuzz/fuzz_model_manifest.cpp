// The MODEL folder's manifest (apps/workflow/model_folder.cpp, model.json): load_model() on a
// folder holding the fuzzed manifest alone, so every input ends at the manifest's checks or at
// the first file it names.
#include "fuzz_input.hpp"

#include "apps/workflow/model_folder.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = brainshift::fuzz::as_file(data, size, "model.json");
  brainshift::fuzz::expect_refusal_or_success(
      [&] { (void)brainshift::workflow::load_model(file.parent_path()); });
  return 0;
}
