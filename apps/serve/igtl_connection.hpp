#pragma once
/// @file
/// @brief One OpenIGTLink connection (a TCP socket of libopenigtlink): messages received whole and
/// checked before anything is allocated or trusted, messages sent from any thread.
///
/// Reception reads the 58-byte header, then the body it announces: header version 1 (protocol 2,
/// PLUS) or 2 (protocol 3, Slicer's default), whose extended header and metadata are dropped and
/// whose content is read as a version-1 body. What comes back (Incoming):
/// - IMAGE of a device the caller wants: unpacked with its CRC checked (the voxels are checked
///   by volume_from_image());
/// - a message the caller does not need (another device's IMAGE, TRANSFORM, STATUS, ...): its body
///   skipped, `ignored` set;
/// - a bad message whose body could be skipped (unknown type, a CRC that does not match, a header
///   version other than 1 and 2, inconsistent extended-header sizes, an IMAGE shorter than its
///   own header): `problem` set, the connection stays usable;
/// - a body larger than the volume ceiling (BRAINSHIFT_MAX_VOLUME_GB): `problem` and `fatal` set:
///   nothing is allocated and the connection must be closed (the stream cannot be resynchronised
///   cheaply).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <igtlMessageBase.h>
#include <igtlSocket.h>
#include <mutex>
#include <optional>
#include <string>

namespace brainshift::serve {

/// A message received (see the file comment).
struct Incoming {
  std::string type;                    ///< e.g. "IMAGE"
  std::string device;                  ///< device name
  std::uint64_t body_bytes = 0;        ///< as announced by the header
  igtl::MessageBase::Pointer message;  ///< unpacked (IMAGE of a wanted device), else null
  bool ignored = false;                ///< not needed: body skipped
  std::string problem;                 ///< non-empty: a bad message (one line)
  int status_code = 0;                 ///< the STATUS code to answer `problem` with
  bool fatal = false;                  ///< the connection cannot go on
  /// When the body's last byte arrived (before its CRC was checked): a latency's start.
  std::chrono::steady_clock::time_point complete;
};

class Connection {
 public:
  /// Takes a connected socket; receive() polls every `poll_ms` for `stop`.
  explicit Connection(igtl::Socket::Pointer socket, int poll_ms = 200);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// Waits for the next message. `wanted(type, device)` says whether to unpack it. Returns
  /// nullopt when the peer closed the connection, the socket failed, or `stop` became true.
  std::optional<Incoming> receive(
      const std::atomic<bool>& stop,
      const std::function<bool(const std::string&, const std::string&)>& wanted);

  /// Packs nothing: sends a packed message whole. Safe from any thread. False when the
  /// connection is lost (then every later send() is false too).
  bool send(igtl::MessageBase* message);

  /// True until the peer closes, a send or receive fails, or close() is called.
  [[nodiscard]] bool open() const { return m_open.load(); }
  void close();

 private:
  enum class Read { DONE, CLOSED, STOPPED };
  Read read_fully(void* buffer, std::uint64_t bytes, const std::atomic<bool>& stop);
  Read skip(std::uint64_t bytes, const std::atomic<bool>& stop);

  igtl::Socket::Pointer m_socket;
  std::mutex m_send;
  std::atomic<bool> m_open{true};
};

}  // namespace brainshift::serve
