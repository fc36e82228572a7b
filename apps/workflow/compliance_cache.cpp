#include "apps/workflow/compliance_cache.hpp"

#include "core/error.hpp"
#include "core/hash.hpp"
#include "imaging/io/atomic_write.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <vector>

namespace brainshift::workflow {
namespace {

using imaging::write_atomically;

static_assert(std::endian::native == std::endian::little,
              "compliance cache I/O assumes a little-endian machine");

constexpr char magic[8] = {'B', 'S', 'C', 'O', 'M', 'P', 'L', '\0'};

/// Streams bytes to a file while hashing them (FNV-1a 64).
class HashingWriter {
 public:
  explicit HashingWriter(std::ofstream& out) : m_out(out) {}
  void put(const void* data, std::size_t bytes) {
    m_hash = core::fnv1a(data, bytes, m_hash);
    m_out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  }
  template <typename T>
  void put(const T& v) {
    put(&v, sizeof v);
  }
  [[nodiscard]] std::uint64_t hash() const { return m_hash; }

 private:
  std::ofstream& m_out;
  std::uint64_t m_hash = core::fnv1a_offset;
};

/// Reads the file in order, hashing every byte it hands out (FNV-1a 64, as HashingWriter), with
/// bounds checks against the file's size: the block's values go from the file straight into the
/// matrix, without a copy of the whole file.
class Reader {
 public:
  explicit Reader(const std::filesystem::path& path)
      : m_path(path), m_in(path, std::ios::binary | std::ios::ate) {
    BS_VERIFY(m_in.good(), path.string() << ": cannot read");
    m_size = static_cast<std::size_t>(m_in.tellg());
    m_in.seekg(0);
  }
  void get(void* data, std::size_t bytes) {
    BS_VERIFY(bytes <= remaining(), m_path.string()
                                        << ": truncated compliance cache (run prepare again)");
    m_in.read(static_cast<char*>(data), static_cast<std::streamsize>(bytes));
    BS_VERIFY(m_in.good(), m_path.string() << ": cannot read");
    m_hash = core::fnv1a(data, bytes, m_hash);
    m_pos += bytes;
  }
  template <typename T>
  T get() {
    T v;
    get(&v, sizeof v);
    return v;
  }
  [[nodiscard]] std::size_t size() const { return m_size; }
  [[nodiscard]] std::size_t remaining() const { return m_size - m_pos; }
  /// FNV-1a of every byte read so far.
  [[nodiscard]] std::uint64_t hash() const { return m_hash; }

 private:
  std::filesystem::path m_path;
  std::ifstream m_in;
  std::size_t m_size = 0, m_pos = 0;
  std::uint64_t m_hash = core::fnv1a_offset;
};

/// The upper triangle of a square matrix set from its lower one, in tiles (a column-major
/// transpose touches a new cache line per entry otherwise).
void mirror_lower(Eigen::MatrixXd& m) {
  constexpr Eigen::Index tile = 64;
  const Eigen::Index n = m.rows();
  for (Eigen::Index j0 = 0; j0 < n; j0 += tile)
    for (Eigen::Index i0 = j0; i0 < n; i0 += tile)
      for (Eigen::Index i = i0; i < std::min(i0 + tile, n); ++i)  // row i of the upper part
        for (Eigen::Index j = j0; j < std::min({j0 + tile, n, i}); ++j) m(j, i) = m(i, j);
}

}  // namespace

void write_compliance_cache(const std::filesystem::path& path,
                            const constraints::ComplianceBlock& block) {
  const auto nb = static_cast<Eigen::Index>(3 * block.nodes.size());
  BS_VERIFY(block.matrix.rows() == nb && block.matrix.cols() == nb,
            path.string() << ": compliance block is " << block.matrix.rows() << "x"
                          << block.matrix.cols() << " for " << block.nodes.size() << " nodes");
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    BS_VERIFY(out.good(), tmp.string() << ": cannot open for writing");
    HashingWriter w(out);
    w.put(magic, sizeof magic);
    w.put(static_cast<std::uint32_t>(compliance_cache_version));
    w.put(std::uint32_t{0});
    w.put(static_cast<std::uint64_t>(block.fingerprint));
    w.put(static_cast<std::int64_t>(block.nodes.size()));
    for (index_t n : block.nodes) w.put(static_cast<std::int64_t>(n));
    for (Eigen::Index j = 0; j < nb; ++j)
      w.put(block.matrix.col(j).data() + j, sizeof(double) * static_cast<std::size_t>(nb - j));
    const std::uint64_t h = w.hash();
    out.write(reinterpret_cast<const char*>(&h), sizeof h);
    out.close();
    BS_VERIFY(out.good(), tmp.string() << ": write failed (disk full?)");
  });
}

constraints::ComplianceBlock read_compliance_cache(const std::filesystem::path& path) {
  Reader r(path);
  const std::size_t size = r.size();

  char m[8];
  BS_VERIFY(size >= sizeof m, path.string() << ": not a brainshift compliance cache (too short)");
  r.get(m, sizeof m);
  BS_VERIFY(std::memcmp(m, magic, sizeof m) == 0, path.string()
                                                      << ": not a brainshift compliance cache");
  const auto version = r.get<std::uint32_t>();
  BS_VERIFY(version == compliance_cache_version,
            path.string() << ": compliance cache version " << version << ", this brainshift reads "
                          << compliance_cache_version << " (run prepare again)");
  (void)r.get<std::uint32_t>();
  constraints::ComplianceBlock b;
  b.fingerprint = r.get<std::uint64_t>();
  const auto count = r.get<std::int64_t>();
  // Each node costs at least 8 bytes of index: a count beyond the file size is corruption, and
  // checking it first keeps a corrupted count from allocating terabytes.
  BS_VERIFY(count >= 0 && static_cast<std::uint64_t>(count) <= r.remaining() / 8,
            path.string() << ": corrupted compliance cache (node count " << count << ")");
  b.nodes.resize(static_cast<std::size_t>(count));
  for (auto& n : b.nodes) n = static_cast<index_t>(r.get<std::int64_t>());
  const auto nb = static_cast<Eigen::Index>(3 * count);
  const std::size_t values = static_cast<std::size_t>(nb) * static_cast<std::size_t>(nb + 1) / 2;
  BS_VERIFY(r.remaining() == values * sizeof(double) + sizeof(std::uint64_t),
            path.string() << ": truncated or corrupted compliance cache (" << r.remaining()
                          << " bytes left, expected "
                          << values * sizeof(double) + sizeof(std::uint64_t)
                          << "; run prepare again)");
  b.matrix.resize(nb, nb);
  for (Eigen::Index j = 0; j < nb; ++j)
    r.get(b.matrix.col(j).data() + j, sizeof(double) * static_cast<std::size_t>(nb - j));
  mirror_lower(b.matrix);
  const std::uint64_t expected = r.hash();
  BS_VERIFY(r.get<std::uint64_t>() == expected,
            path.string() << ": corrupted compliance cache (checksum mismatch; run prepare again)");
  return b;
}

}  // namespace brainshift::workflow
