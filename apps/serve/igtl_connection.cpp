#include "apps/serve/igtl_connection.hpp"

#include "apps/serve/igtl_messages.hpp"
#include "core/logger.hpp"
#include "imaging/io/header_checks.hpp"

#include <climits>

#include <algorithm>
#include <array>
#include <cstring>
#include <igtlImageMessage.h>
#include <igtlMessageHeader.h>
#include <igtlStatusMessage.h>
#include <igtl_util.h>
#include <set>
#include <sstream>
#include <vector>

namespace brainshift::serve {
namespace {

constexpr std::size_t header_bytes = 58;  // IGTL_HEADER_SIZE

std::uint64_t big_endian(const unsigned char* p, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | p[i];
  return v;
}

/// A fixed-width, zero-padded ASCII field.
std::string field(const unsigned char* p, std::size_t n) {
  std::string s(reinterpret_cast<const char*>(p), n);
  s.resize(std::strlen(s.c_str()));
  return s;
}

/// Types a PLUS server or Slicer sends that brainshift has no use for: skipped quietly.
bool known_type(const std::string& type) {
  static const std::set<std::string> known = {
      "IMAGE",      "TRANSFORM", "STATUS",  "STRING", "POSITION", "TDATA",      "QTDATA",
      "POINT",      "POLYDATA",  "IMGMETA", "LBMETA", "COLORT",   "SENSOR",     "NDARRAY",
      "CAPABILITY", "TRAJ",      "BIND",    "QTRANS", "COMMAND",  "RTS_COMMAND"};
  if (known.count(type)) return true;
  for (const char* prefix : {"GET_", "STT_", "STP_", "RTS_"})
    if (type.rfind(prefix, 0) == 0) return true;
  return false;
}

}  // namespace

Connection::Connection(igtl::Socket::Pointer socket, int poll_ms) : m_socket(std::move(socket)) {
  m_socket->SetReceiveTimeout(poll_ms);
}

Connection::~Connection() { close(); }

void Connection::close() {
  const std::lock_guard<std::mutex> lock(m_send);
  m_open = false;
  if (m_socket->GetConnected()) m_socket->CloseSocket();
}

Connection::Read Connection::read_fully(void* buffer, std::uint64_t bytes,
                                        const std::atomic<bool>& stop) {
  auto* p = static_cast<char*>(buffer);
  std::uint64_t got = 0;
  while (got < bytes) {
    if (stop.load()) return Read::STOPPED;
    if (!m_open.load()) return Read::CLOSED;
    const int want = int(std::min<std::uint64_t>(bytes - got, 1u << 24));
    // With a receive timeout, libopenigtlink returns what arrived (−1: nothing before the
    // timeout, 0: the peer closed or the socket failed).
    const int n = m_socket->Receive(p + got, want, 0);
    if (n == -1) continue;
    if (n <= 0) {
      m_open = false;
      return Read::CLOSED;
    }
    got += std::uint64_t(n);
  }
  return Read::DONE;
}

Connection::Read Connection::skip(std::uint64_t bytes, const std::atomic<bool>& stop) {
  std::vector<char> sink(std::min<std::uint64_t>(bytes, 1u << 20));
  while (bytes > 0) {
    const std::uint64_t n = std::min<std::uint64_t>(bytes, sink.size());
    const Read r = read_fully(sink.data(), n, stop);
    if (r != Read::DONE) return r;
    bytes -= n;
  }
  return Read::DONE;
}

std::optional<Incoming> Connection::receive(
    const std::atomic<bool>& stop,
    const std::function<bool(const std::string&, const std::string&)>& wanted) {
  std::array<unsigned char, header_bytes> h{};
  if (read_fully(h.data(), h.size(), stop) != Read::DONE) return std::nullopt;
  Incoming in;
  const auto version = big_endian(h.data(), 2);
  in.type = field(h.data() + 2, 12);
  in.device = field(h.data() + 14, 20);
  in.body_bytes = big_endian(h.data() + 42, 8);
  const std::string what = in.type + " '" + in.device + "'";

  // The body's size first: nothing is allocated for a claim above the ceiling.
  const double ceiling = std::min(imaging::max_volume_bytes() + double(image_header_bytes),
                                  double(INT_MAX - int(header_bytes)));
  if (double(in.body_bytes) > ceiling) {
    std::ostringstream o;
    o << what << ": a body of " << in.body_bytes << " bytes, above the " << std::uint64_t(ceiling)
      << "-byte limit (BRAINSHIFT_MAX_VOLUME_GB, at most OpenIGTLink's 2 GiB); closing the "
         "connection";
    in.problem = o.str();
    in.status_code = igtl::StatusMessage::STATUS_OVERFLOW;
    in.fatal = true;
    return in;
  }
  auto skip_with = [&](std::string problem, int code) -> std::optional<Incoming> {
    if (skip(in.body_bytes, stop) != Read::DONE) return std::nullopt;
    in.problem = std::move(problem);
    in.status_code = code;
    in.ignored = in.problem.empty();
    return in;
  };
  if (version != 1 && version != 2)
    return skip_with(what + ": header version " + std::to_string(version) +
                         " (brainshift reads versions 1 and 2: OpenIGTLink protocols 2 and 3)",
                     igtl::StatusMessage::STATUS_UNKNOWN_VERSION);
  if (!known_type(in.type))
    return skip_with(what + ": unknown message type",
                     igtl::StatusMessage::STATUS_UNKNOWN_INSTRUCTION);
  if (!wanted(in.type, in.device) || in.type != "IMAGE") return skip_with("", 0);
  if (version == 1 && in.body_bytes < image_header_bytes)
    return skip_with(what + ": a body of " + std::to_string(in.body_bytes) +
                         " bytes, shorter than the IMAGE header (72)",
                     igtl::StatusMessage::STATUS_CONFIG_ERROR);
  auto refuse = [&](std::string problem, int code) {
    in.problem = std::move(problem);
    in.status_code = code;
    return std::optional<Incoming>(in);
  };
  const std::uint64_t crc = big_endian(h.data() + 50, 8);
  const char* crc_problem = ": the body's CRC64 does not match the header's (damaged message)";

  // Header version 2 (protocol 3, Slicer's default): the body is an extended header, the content
  // (a version-1 body), a metadata header and the metadata. The CRC covers the whole body.
  std::vector<unsigned char> whole;
  std::uint64_t begin = 0;
  if (version == 2) {
    whole.resize(in.body_bytes);
    if (read_fully(whole.data(), in.body_bytes, stop) != Read::DONE) return std::nullopt;
    in.complete = std::chrono::steady_clock::now();
    if (crc64(whole.data(), in.body_bytes, 0) != crc)
      return refuse(what + crc_problem, igtl::StatusMessage::STATUS_CHECKSUM_ERROR);
    const std::uint64_t ext = in.body_bytes >= 12 ? big_endian(whole.data(), 2) : 0;
    const std::uint64_t meta =
        in.body_bytes >= 12 ? big_endian(whole.data() + 2, 2) + big_endian(whole.data() + 4, 4) : 0;
    if (ext < 12 || ext + meta > in.body_bytes)
      return refuse(what + ": header version 2 with an extended header of " + std::to_string(ext) +
                        " bytes and " + std::to_string(meta) + " bytes of metadata in a body of " +
                        std::to_string(in.body_bytes),
                    igtl::StatusMessage::STATUS_CONFIG_ERROR);
    begin = ext;
    in.body_bytes -= ext + meta;  // the content's
    if (in.body_bytes < image_header_bytes)
      return refuse(what + ": content of " + std::to_string(in.body_bytes) +
                        " bytes, shorter than the IMAGE header (72)",
                    igtl::StatusMessage::STATUS_CONFIG_ERROR);
  }
  // libopenigtlink 1.11 reads version-1 messages: the header says so, with the content's size.
  std::array<unsigned char, header_bytes> h1 = h;
  h1[0] = 0;
  h1[1] = 1;
  for (int b = 0; b < 8; ++b) h1[std::size_t(42 + b)] = (in.body_bytes >> (56 - 8 * b)) & 0xff;
  auto header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), h1.data(), h1.size());
  header->Unpack();
  igtl::MessageBase::Pointer message;
  message = igtl::ImageMessage::New();
  message->SetMessageHeader(header);
  message->AllocatePack();
  auto* body = static_cast<unsigned char*>(message->GetPackBodyPointer());
  if (version == 2) {
    std::memcpy(body, whole.data() + begin, in.body_bytes);
    whole = {};
  } else {
    if (read_fully(body, in.body_bytes, stop) != Read::DONE) return std::nullopt;
    in.complete = std::chrono::steady_clock::now();
    if (crc64(body, in.body_bytes, 0) != crc)
      return refuse(what + crc_problem, igtl::StatusMessage::STATUS_CHECKSUM_ERROR);
  }
  const int unpacked = message->Unpack(0);  // the CRC is checked above
  if (!(unpacked & igtl::MessageHeader::UNPACK_BODY))
    return refuse(what + ": the body could not be unpacked (IMAGE header version " +
                      std::to_string(big_endian(body, 2)) + "; brainshift reads version 1)",
                  igtl::StatusMessage::STATUS_UNKNOWN_VERSION);
  in.message = message;
  return in;
}

bool Connection::send(igtl::MessageBase* message) {
  const std::lock_guard<std::mutex> lock(m_send);
  if (!m_open.load()) return false;
  if (m_socket->Send(message->GetPackPointer(), message->GetPackSize()) != 1) {
    logger().warn("OpenIGTLink: sending {} '{}' failed; the connection is closed",
                  message->GetDeviceType(), message->GetDeviceName());
    m_open = false;
    return false;
  }
  return true;
}

}  // namespace brainshift::serve
