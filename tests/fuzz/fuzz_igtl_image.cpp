// An OpenIGTLink message as `brainshift serve` receives it (apps/serve): the 58-byte header's
// fields as the connection reads them, then an IMAGE body unpacked by libopenigtlink and checked
// by volume_from_image(). The body size is the input's, as the connection reads exactly the
// bytes announced (a header that announces more than arrives is a closed connection there).
#include "fuzz_input.hpp"

#include "apps/serve/igtl_messages.hpp"

#include <cstring>
#include <igtlMessageHeader.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t header = 58;
  if (size < header + brainshift::serve::image_header_bytes) return 0;  // refused before unpacking
  auto h = igtl::MessageHeader::New();
  h->InitPack();
  std::memcpy(h->GetPackPointer(), data, header);
  // The connection's framing: version 1, type IMAGE, the body that follows.
  auto* raw = static_cast<unsigned char*>(h->GetPackPointer());
  raw[0] = 0;
  raw[1] = 1;
  std::memcpy(raw + 2, "IMAGE\0\0\0\0\0\0\0", 12);
  const std::uint64_t body = size - header;
  for (int b = 0; b < 8; ++b) raw[42 + b] = std::uint8_t(body >> (56 - 8 * b));
  h->Unpack();
  auto m = igtl::ImageMessage::New();
  m->SetMessageHeader(h);
  m->AllocatePack();
  std::memcpy(m->GetPackBodyPointer(), data + header, body);
  if (!(m->Unpack(0) & igtl::MessageHeader::UNPACK_BODY)) return 0;  // refused (version)
  brainshift::fuzz::expect_refusal_or_success(
      [&] { (void)brainshift::serve::volume_from_image(*m, body, "fuzz"); });
  return 0;
}
