#include "imaging/io/landmark_files.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/text_util.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>

namespace brainshift::imaging {
namespace {

/// A landmark file is a few kB; anything near this is not one (and is not read into memory).
constexpr std::uintmax_t max_landmark_file_bytes = 64ULL << 20;

bool ends_with(const std::string& s, std::string_view suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string read_text(const std::filesystem::path& path) {
  std::error_code ec;
  BS_VERIFY(std::filesystem::is_regular_file(path, ec), path.string() << ": no such file");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  BS_VERIFY(!ec && size <= max_landmark_file_bytes,
            path.string() << ": " << size << " bytes is not a landmark file (limit "
                          << (max_landmark_file_bytes >> 20) << " MiB)");
  std::ifstream in(path, std::ios::binary);
  BS_VERIFY(in.good(), path.string() << ": cannot open for reading");
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);  // UTF-8 byte-order mark
  return text;
}

/// Parses a whole field as a finite number; false otherwise.
bool parse_double(std::string_view field, double& value) {
  if (!field.empty() && field.front() == '+') field.remove_prefix(1);
  const auto [end, err] = std::from_chars(field.data(), field.data() + field.size(), value);
  return err == std::errc() && end == field.data() + field.size() && std::isfinite(value);
}

/// Collects points with unique ids; `where` names the point in errors.
class LandmarkSet {
 public:
  explicit LandmarkSet(std::string file) : m_file(std::move(file)) {}

  void add(std::string id, const Vector3d& ras, const std::string& where) {
    BS_VERIFY(ras.allFinite(), where << ": a coordinate is not a finite number");
    const auto [it, inserted] = m_seen.emplace(id, where);
    BS_VERIFY(inserted, where << ": id " << id << " is repeated (first at " << it->second << ")");
    m_ids.push_back(std::move(id));
    m_points.push_back(ras);
  }

  Landmarks take() {
    BS_VERIFY(!m_ids.empty(), m_file << ": no landmarks in the file");
    Landmarks l;
    l.ids = std::move(m_ids);
    l.points.resize(static_cast<Eigen::Index>(m_points.size()), 3);
    for (std::size_t i = 0; i < m_points.size(); ++i)
      l.points.row(static_cast<Eigen::Index>(i)) = m_points[i].transpose();
    return l;
  }

 private:
  std::string m_file;
  std::vector<std::string> m_ids;
  std::vector<Vector3d> m_points;
  std::unordered_map<std::string, std::string> m_seen;
};

Vector3d lps_to_ras(const Vector3d& p) { return {-p.x(), -p.y(), p.z()}; }

// ---- MNI tag files -------------------------------------------------------------------------

/// One point line of a tag file: the numbers and the label (quotes removed), ';' noted.
struct TagLine {
  std::vector<double> numbers;
  std::string label;
  bool ends_list = false;
};

TagLine split_tag_line(std::string_view line, const std::string& where) {
  TagLine t;
  std::size_t i = 0;
  while (i < line.size()) {
    const char c = line[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else if (c == ';') {
      t.ends_list = true;
      BS_VERIFY(trim(line.substr(i + 1)).empty(), where << ": text after the closing ';'");
      break;
    } else if (c == '"') {
      const auto close = line.find('"', i + 1);
      BS_VERIFY(close != std::string_view::npos, where << ": a label's closing quote is missing");
      t.label = std::string(line.substr(i + 1, close - i - 1));
      i = close + 1;
    } else {
      const auto end = line.find_first_of(" \t\r\";", i);
      const std::string_view token =
          line.substr(i, end == std::string_view::npos ? std::string_view::npos : end - i);
      double v = 0;
      BS_VERIFY(parse_double(token, v),
                where << ": expected a finite number, got '" << token << "'");
      BS_VERIFY(t.label.empty(), where << ": a number after the label");
      t.numbers.push_back(v);
      i += token.size();
    }
  }
  return t;
}

Landmarks read_tag(const std::filesystem::path& path, TagVolume volume) {
  const std::string file = path.string();
  const std::string text = read_text(path);
  std::istringstream in(text);
  std::string line;
  int number = 0;
  const auto where = [&] { return file + ":" + std::to_string(number); };
  // Header: the magic line, then `Volumes = N;`, comments (%) and other keys, then `Points =`.
  std::string_view first;
  while (first.empty() && std::getline(in, line)) {
    ++number;
    first = trim(line);
  }
  BS_VERIFY(first == "MNI Tag Point File",
            file << ": not an MNI tag file (the first line is not 'MNI Tag Point File')");
  int volumes = 0;
  bool points = false;
  while (!points && std::getline(in, line)) {
    ++number;
    std::string_view l = trim(line);
    if (l.empty() || l.front() == '%') continue;
    const auto eq = l.find('=');
    BS_VERIFY(eq != std::string_view::npos, where()
                                                << ": expected 'key = value;', got '" << l << "'");
    const std::string_view key = trim(l.substr(0, eq));
    std::string_view value = trim(l.substr(eq + 1));
    if (key == "Points") {
      points = true;
      BS_VERIFY(value.empty(), where() << ": points must start on the line after 'Points ='");
    } else if (key == "Volumes") {
      if (!value.empty() && value.back() == ';') value.remove_suffix(1);
      value = trim(value);
      BS_VERIFY(value == "1" || value == "2",
                where() << ": Volumes must be 1 or 2, got '" << value << "'");
      volumes = value == "1" ? 1 : 2;
    }
  }
  BS_VERIFY(volumes > 0, file << ": no 'Volumes = 1;' or 'Volumes = 2;' before the points");
  BS_VERIFY(points, file << ": no 'Points =' line");
  const int offset = volumes == 2 && volume == TagVolume::SECOND ? 3 : 0;
  LandmarkSet set(file);
  bool ended = false;
  int index = 0;
  while (!ended && std::getline(in, line)) {
    ++number;
    const std::string_view l = trim(line);
    if (l.empty()) continue;
    const TagLine t = split_tag_line(l, where());
    ended = t.ends_list;
    if (t.numbers.empty() && t.label.empty()) continue;  // a lone ';'
    const auto n = static_cast<int>(t.numbers.size());
    BS_VERIFY(n == 3 * volumes || n == 3 * volumes + 3,
              where() << ": expected " << 3 * volumes << " coordinates (optionally followed by "
                      << "weight, structure id and patient id), got " << n << " numbers");
    ++index;
    const Vector3d p(t.numbers[offset], t.numbers[offset + 1], t.numbers[offset + 2]);
    set.add(t.label.empty() ? std::to_string(index) : t.label, p, where());
  }
  BS_VERIFY(ended, file << ": the point list does not end with ';' (truncated file?)");
  return set.take();
}

// ---- Slicer markups JSON -------------------------------------------------------------------

Landmarks read_markups_json(const std::filesystem::path& path) {
  const std::string file = path.string();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text(path));
  } catch (const nlohmann::json::parse_error& e) {
    BS_THROW(file << ": not valid JSON (at byte " << e.byte << ")");
  } catch (const nlohmann::json::exception&) {  // e.g. a number beyond double's range (fuzzing)
    BS_THROW(file << ": not valid JSON (a number out of range)");
  }
  BS_VERIFY(j.is_object() && j.contains("markups") && j["markups"].is_array(),
            file << ": not a Slicer markups file (no 'markups' list)");
  LandmarkSet set(file);
  int index = 0;
  for (std::size_t m = 0; m < j["markups"].size(); ++m) {
    const nlohmann::json& mk = j["markups"][m];
    const std::string mw = file + ": markups[" + std::to_string(m) + "]";
    BS_VERIFY(mk.is_object(), mw << " is not an object");
    std::string system = "LPS";
    if (mk.contains("coordinateSystem")) {
      BS_VERIFY(mk["coordinateSystem"].is_string(), mw << ": coordinateSystem is not a string");
      system = mk["coordinateSystem"].get<std::string>();
    }
    BS_VERIFY(system == "LPS" || system == "RAS",
              mw << ": coordinateSystem must be LPS or RAS, got '" << system << "'");
    if (!mk.contains("controlPoints")) continue;
    BS_VERIFY(mk["controlPoints"].is_array(), mw << ": controlPoints is not a list");
    for (std::size_t c = 0; c < mk["controlPoints"].size(); ++c) {
      const nlohmann::json& cp = mk["controlPoints"][c];
      const std::string cw = mw + ".controlPoints[" + std::to_string(c) + "]";
      BS_VERIFY(cp.is_object(), cw << " is not an object");
      ++index;
      if (cp.contains("positionStatus") && cp["positionStatus"].is_string()) {
        const std::string status = cp["positionStatus"].get<std::string>();
        if (status == "undefined" || status == "missing") continue;
      }
      BS_VERIFY(cp.contains("position") && cp["position"].is_array() &&
                    cp["position"].size() == 3 &&
                    std::all_of(cp["position"].begin(), cp["position"].end(),
                                [](const nlohmann::json& v) { return v.is_number(); }),
                cw << ": position is not a list of three numbers");
      const Vector3d p(cp["position"][0].get<double>(), cp["position"][1].get<double>(),
                       cp["position"][2].get<double>());
      std::string id;
      for (const char* key : {"label", "id"})
        if (id.empty() && cp.contains(key) && cp[key].is_string()) id = cp[key].get<std::string>();
      if (id.empty()) id = std::to_string(index);
      set.add(std::move(id), system == "LPS" ? lps_to_ras(p) : p, cw);
    }
  }
  return set.take();
}

// ---- Slicer fiducial CSV -------------------------------------------------------------------

/// Splits one CSV line; double-quoted fields may hold commas ("" is a quote).
std::vector<std::string> split_quoted(std::string_view line, const std::string& where) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  BS_VERIFY(!quoted, where << ": a quoted field is not closed");
  for (auto& f : fields) f = std::string(trim(f));
  return fields;
}

Landmarks read_fcsv(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string text = read_text(path);
  std::istringstream in(text);
  std::string line;
  int number = 0;
  const auto where = [&] { return file + ":" + std::to_string(number); };
  bool lps = false;  // Slicer <= 4.10 wrote RAS without saying so
  std::vector<std::string> columns = {
      "id", "x",   "y",   "z",    "ow",    "ox",   "oy",
      "oz", "vis", "sel", "lock", "label", "desc", "associatedNodeID"};
  LandmarkSet set(file);
  while (std::getline(in, line)) {
    ++number;
    const std::string_view l = trim(line);
    if (l.empty()) continue;
    if (l.front() == '#') {
      const std::string_view body = trim(l.substr(1));
      const auto eq = body.find('=');
      if (eq == std::string_view::npos) continue;
      const std::string key = lower_case(std::string(trim(body.substr(0, eq))));
      const std::string_view value = trim(body.substr(eq + 1));
      if (key == "coordinatesystem") {
        BS_VERIFY(value == "LPS" || value == "RAS" || value == "0" || value == "1",
                  where() << ": CoordinateSystem must be LPS, RAS, 0 (RAS) or 1 (LPS), got '"
                          << value << "'");
        lps = value == "LPS" || value == "1";
      } else if (key == "columns") {
        columns = split_quoted(value, where());
      }
      continue;
    }
    const auto column = [&](const std::string& name) -> std::ptrdiff_t {
      const auto it = std::find(columns.begin(), columns.end(), name);
      return it == columns.end() ? -1 : it - columns.begin();
    };
    const std::ptrdiff_t cx = column("x"), cy = column("y"), cz = column("z");
    BS_VERIFY(cx >= 0 && cy >= 0 && cz >= 0, where() << ": the columns line names no x, y and z");
    const std::vector<std::string> f = split_quoted(l, where());
    const auto need = static_cast<std::size_t>(std::max({cx, cy, cz})) + 1;
    BS_VERIFY(f.size() >= need,
              where() << ": expected at least " << need << " fields, got " << f.size());
    Vector3d p;
    const std::ptrdiff_t cs[3] = {cx, cy, cz};
    for (int a = 0; a < 3; ++a)
      BS_VERIFY(parse_double(f[static_cast<std::size_t>(cs[a])], p[a]),
                where() << ": expected a finite number for "
                        << "xyz"[a] << ", got '" << f[static_cast<std::size_t>(cs[a])] << "'");
    std::string id;
    for (const char* name : {"label", "id"}) {
      const std::ptrdiff_t c = column(name);
      if (id.empty() && c >= 0 && static_cast<std::size_t>(c) < f.size())
        id = f[static_cast<std::size_t>(c)];
    }
    BS_VERIFY(!id.empty(), where() << ": the point has neither a label nor an id");
    set.add(std::move(id), lps ? lps_to_ras(p) : p, where());
  }
  return set.take();
}

}  // namespace

bool is_landmark_file(const std::filesystem::path& path) {
  const std::string name = lower_case(path.filename().string());
  return ends_with(name, ".csv") || ends_with(name, ".tag") || ends_with(name, ".mrk.json") ||
         ends_with(name, ".fcsv");
}

Landmarks read_landmark_file(const std::filesystem::path& path, TagVolume volume) {
  const std::string name = lower_case(path.filename().string());
  if (ends_with(name, ".csv")) return read_landmarks(path);
  if (ends_with(name, ".tag")) return read_tag(path, volume);
  if (ends_with(name, ".mrk.json")) return read_markups_json(path);
  if (ends_with(name, ".fcsv")) return read_fcsv(path);
  BS_THROW(path.string() << ": unknown landmark format (expected .csv, .tag, .mrk.json or .fcsv)");
}

void write_markups_json(const std::filesystem::path& path, const Landmarks& landmarks,
                        const std::vector<std::string>& descriptions) {
  BS_VERIFY(static_cast<Eigen::Index>(landmarks.ids.size()) == landmarks.points.rows(),
            path.string() << ": " << landmarks.ids.size() << " ids for " << landmarks.points.rows()
                          << " points");
  BS_VERIFY(descriptions.empty() || descriptions.size() == landmarks.ids.size(),
            path.string() << ": " << descriptions.size() << " descriptions for "
                          << landmarks.ids.size() << " landmarks");
  nlohmann::json points = nlohmann::json::array();
  for (std::size_t i = 0; i < landmarks.ids.size(); ++i) {
    const Vector3d lps = lps_to_ras(landmarks.points.row(static_cast<Eigen::Index>(i)).transpose());
    points.push_back({{"id", std::to_string(i + 1)},
                      {"label", landmarks.ids[i]},
                      {"description", descriptions.empty() ? "" : descriptions[i]},
                      {"position", {lps.x(), lps.y(), lps.z()}},
                      {"orientation", {-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0}},
                      {"selected", true},
                      {"locked", true},
                      {"visibility", true},
                      {"positionStatus", "defined"}});
  }
  const nlohmann::json j = {
      {"@schema",
       "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/"
       "Resources/Schema/markups-schema-v1.0.3.json#"},
      {"markups",
       {{{"type", "Fiducial"},
         {"coordinateSystem", "LPS"},
         {"coordinateUnits", "mm"},
         {"locked", true},
         {"controlPoints", points}}}}};
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << j.dump(2) << '\n';  // numbers in their shortest exact form
    out.close();
    BS_VERIFY(out.good(), "cannot write " << path.string());
  });
}

}  // namespace brainshift::imaging
