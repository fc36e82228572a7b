#include "imaging/io/csv.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>

namespace brainshift::imaging {
namespace {

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  for (std::size_t comma = line.find(','); comma != std::string_view::npos;
       start = comma + 1, comma = line.find(',', start)) {
    fields.push_back(trim(line.substr(start, comma - start)));
  }
  fields.push_back(trim(line.substr(start)));
  return fields;
}

/// Non-blank lines of a CSV file with their 1-based line numbers; checks the header.
class CsvReader {
 public:
  CsvReader(const std::filesystem::path& path, std::string_view header) : m_file(path.string()) {
    std::error_code ec;
    BS_VERIFY(std::filesystem::exists(path, ec), m_file << ": no such file");
    m_in.open(path);
    BS_VERIFY(m_in.good(), m_file << ": cannot open for reading");
    std::string_view got;
    BS_VERIFY(next(got), m_file << ": empty file, expected the header '" << header << "'");
    if (got.substr(0, 3) == "\xEF\xBB\xBF") got.remove_prefix(3);  // UTF-8 byte-order mark
    std::string normalised;
    for (const auto f : split_fields(got)) {
      if (!normalised.empty()) normalised += ',';
      normalised.append(f.data(), f.size());
    }
    BS_VERIFY(normalised == header,
              where() << ": expected the header '" << header << "', got '" << got << "'");
  }

  /// Next non-blank line, trimmed; false at the end of the file.
  bool next(std::string_view& line) {
    while (std::getline(m_in, m_line)) {
      ++m_line_number;
      line = trim(m_line);
      if (!line.empty()) return true;
    }
    return false;
  }

  /// "file:line" of the current line.
  [[nodiscard]] std::string where() const { return m_file + ":" + std::to_string(m_line_number); }

  [[nodiscard]] index_t parse_node(std::string_view field, index_t num_nodes) const {
    long long value = -1;
    const auto [end, err] = std::from_chars(field.data(), field.data() + field.size(), value);
    BS_VERIFY(err == std::errc() && end == field.data() + field.size() && value >= 0 &&
                  value <= std::numeric_limits<index_t>::max(),
              where() << ": expected a node id (non-negative integer), got '" << field << "'");
    BS_VERIFY(num_nodes < 0 || value < num_nodes,
              where() << ": node " << value << " is out of range: the mesh has " << num_nodes
                      << " nodes (ids 0 to " << num_nodes - 1 << ")");
    return static_cast<index_t>(value);
  }

  [[nodiscard]] double parse_number(std::string_view field, const char* name) const {
    double value = 0.0;
    if (!field.empty() && field.front() == '+') field.remove_prefix(1);
    const auto [end, err] = std::from_chars(field.data(), field.data() + field.size(), value);
    BS_VERIFY(err == std::errc() && end == field.data() + field.size() && std::isfinite(value),
              where() << ": expected a finite number for " << name << ", got '" << field << "'");
    return value;
  }

 private:
  std::string m_file;
  std::ifstream m_in;
  std::string m_line;
  int m_line_number = 0;
};

void write_text(const std::filesystem::path& path, const std::string& text) {
  write_atomically(path, [&](const std::filesystem::path& temporary) {
    std::ofstream out(temporary, std::ios::binary);
    out << text;
    out.close();
    BS_VERIFY(out.good(), "cannot write " << path.string());
  });
}

}  // namespace

std::vector<index_t> read_node_list(const std::filesystem::path& path, index_t num_nodes) {
  CsvReader csv(path, "node");
  std::vector<index_t> nodes;
  for (std::string_view line; csv.next(line);) {
    const auto fields = split_fields(line);
    BS_VERIFY(fields.size() == 1, csv.where()
                                      << ": expected one field (node), got " << fields.size());
    nodes.push_back(csv.parse_node(fields[0], num_nodes));
  }
  return nodes;
}

std::vector<core::PrescribedDisplacement> read_node_displacements(const std::filesystem::path& path,
                                                                  index_t num_nodes) {
  CsvReader csv(path, "node,dx,dy,dz");
  std::vector<core::PrescribedDisplacement> result;
  std::unordered_map<index_t, std::string> seen;  // node → where it was first given
  for (std::string_view line; csv.next(line);) {
    const auto fields = split_fields(line);
    BS_VERIFY(fields.size() == 4,
              csv.where() << ": expected 4 fields (node,dx,dy,dz), got " << fields.size());
    core::PrescribedDisplacement p;
    p.node = csv.parse_node(fields[0], num_nodes);
    p.displacement = {csv.parse_number(fields[1], "dx"), csv.parse_number(fields[2], "dy"),
                      csv.parse_number(fields[3], "dz")};
    const auto [it, inserted] = seen.emplace(p.node, csv.where());
    BS_VERIFY(inserted,
              csv.where() << ": node " << p.node << " is repeated (first at " << it->second << ")");
    result.push_back(p);
  }
  return result;
}

void write_node_list(const std::filesystem::path& path, const std::vector<index_t>& nodes) {
  std::ostringstream s;
  s << "node\n";
  for (const index_t n : nodes) s << n << '\n';
  write_text(path, s.str());
}

void write_node_displacements(const std::filesystem::path& path,
                              const std::vector<core::PrescribedDisplacement>& displacements) {
  std::ostringstream s;
  s.precision(std::numeric_limits<double>::max_digits10);
  s << "node,dx,dy,dz\n";
  for (const auto& p : displacements) {
    s << p.node << ',' << p.displacement.x() << ',' << p.displacement.y() << ','
      << p.displacement.z() << '\n';
  }
  write_text(path, s.str());
}

Landmarks read_landmarks(const std::filesystem::path& path) {
  CsvReader csv(path, "id,x,y,z");
  Landmarks result;
  std::vector<Vector3d> points;
  std::unordered_map<std::string, std::string> seen;  // id → where it was first given
  for (std::string_view line; csv.next(line);) {
    const auto fields = split_fields(line);
    BS_VERIFY(fields.size() == 4, csv.where()
                                      << ": expected 4 fields (id,x,y,z), got " << fields.size());
    std::string id(fields[0]);
    BS_VERIFY(!id.empty(), csv.where() << ": empty id");
    const auto [it, inserted] = seen.emplace(id, csv.where());
    BS_VERIFY(inserted, csv.where()
                            << ": id " << id << " is repeated (first at " << it->second << ")");
    points.emplace_back(csv.parse_number(fields[1], "x"), csv.parse_number(fields[2], "y"),
                        csv.parse_number(fields[3], "z"));
    result.ids.push_back(std::move(id));
  }
  result.points.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i)
    result.points.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  return result;
}

void write_landmarks(const std::filesystem::path& path, const Landmarks& landmarks) {
  BS_VERIFY(static_cast<Eigen::Index>(landmarks.ids.size()) == landmarks.points.rows(),
            path.string() << ": " << landmarks.ids.size() << " ids for " << landmarks.points.rows()
                          << " points");
  std::ostringstream s;
  s.precision(std::numeric_limits<double>::max_digits10);
  s << "id,x,y,z\n";
  for (std::size_t i = 0; i < landmarks.ids.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    s << landmarks.ids[i] << ',' << landmarks.points(r, 0) << ',' << landmarks.points(r, 1) << ','
      << landmarks.points(r, 2) << '\n';
  }
  write_text(path, s.str());
}

}  // namespace brainshift::imaging
