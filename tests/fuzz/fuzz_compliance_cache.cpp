// The MODEL folder's compliance cache (apps/workflow/compliance_cache.cpp, compliance.bin):
// magic, version, node count, the packed upper triangle and the FNV-1a checksum.
#include "fuzz_input.hpp"

#include "apps/workflow/compliance_cache.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = brainshift::fuzz::as_file(data, size, "compliance.bin");
  brainshift::fuzz::expect_refusal_or_success(
      [&] { (void)brainshift::workflow::read_compliance_cache(file); });
  return 0;
}
