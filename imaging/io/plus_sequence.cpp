#include "imaging/io/plus_sequence.hpp"

#include "core/error.hpp"
#include "imaging/io/text_util.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

std::vector<double> parse_numbers(const std::string& text, const std::string& file,
                                  const std::string& field) {
  std::string t = text;
  std::replace(t.begin(), t.end(), ',', ' ');
  std::replace(t.begin(), t.end(), '\t', ' ');
  std::istringstream in(t);
  std::vector<double> v;
  for (std::string w; in >> w;) {
    char* end = nullptr;
    const double x = std::strtod(w.c_str(), &end);
    BS_VERIFY(end && *end == '\0' && std::isfinite(x),
              file << ": " << field << ": '" << w << "' is not a number");
    v.push_back(x);
  }
  return v;
}

Eigen::Matrix4d matrix_of(const std::vector<double>& v, const std::string& file,
                          const std::string& field) {
  BS_VERIFY(v.size() == 16, file << ": " << field << " has " << v.size()
                                 << " numbers, a 4x4 matrix has 16 (row-major)");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[std::size_t(4 * r + c)];
  BS_VERIFY((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() < 1e-6,
            file << ": " << field << ": the last row of a transform must be 0 0 0 1");
  // An image's transform may leave its third column zero (a 2-D image has no thickness): the
  // first two columns must span a plane.
  const Vector3d a = m.block<3, 1>(0, 0), b = m.block<3, 1>(0, 1);
  BS_VERIFY(a.cross(b).norm() > 1e-12 * std::max(1.0, a.squaredNorm() + b.squaredNorm()),
            file << ": " << field << ": singular transform (its first two columns are parallel)");
  return m;
}

struct ElementType {
  int bytes;
  float (*to_float)(const unsigned char*);
};

template <typename T>
float as_float(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return float(v);
}

ElementType element_type(const std::string& name, const std::string& file) {
  if (name == "MET_UCHAR") return {1, as_float<std::uint8_t>};
  if (name == "MET_CHAR") return {1, as_float<std::int8_t>};
  if (name == "MET_USHORT") return {2, as_float<std::uint16_t>};
  if (name == "MET_SHORT") return {2, as_float<std::int16_t>};
  if (name == "MET_UINT") return {4, as_float<std::uint32_t>};
  if (name == "MET_INT") return {4, as_float<std::int32_t>};
  if (name == "MET_FLOAT") return {4, as_float<float>};
  if (name == "MET_DOUBLE") return {8, as_float<double>};
  BS_THROW(file << ": unsupported ElementType '" << name << "'");
}

/// What the two header formats give: the fields (frame fields under their Seq_Frame names), the
/// frame size and count, the element type and encoding, and where the pixels start.
struct SequenceHeader {
  std::map<std::string, std::string> fields;
  int columns = 0, rows = 0;
  std::size_t frames = 0;
  ElementType type{};
  enum class Packing { RAW, ZLIB, GZIP } packing = Packing::RAW;
  std::string orientation = "MF";
};

SequenceHeader metaimage_header(std::istream& in, const std::string& file) {
  SequenceHeader h;
  auto& fields = h.fields;
  std::string line;
  bool data_follows = false;
  constexpr std::size_t max_header_lines = 5'000'000;  // ~20 fields per frame, 250k frames
  for (std::size_t n = 0; std::getline(in, line); ++n) {
    BS_VERIFY(n < max_header_lines, file << ": MetaImage header does not end");
    const auto eq = line.find('=');
    BS_VERIFY(eq != std::string::npos || trim(line).empty(),
              file << ": not a MetaImage sequence header (line " << n + 1 << ": '"
                   << line.substr(0, 60) << "')");
    if (eq == std::string::npos) continue;
    const std::string key = std::string(trim(line.substr(0, eq)));
    const std::string value = std::string(trim(line.substr(eq + 1)));
    if (n == 0)
      BS_VERIFY(key == "ObjectType" || key == "NDims",
                file << ": not a MetaImage file (first line '" << line.substr(0, 60) << "')");
    if (key == "ElementDataFile") {
      BS_VERIFY(value == "LOCAL", file << ": pixel data in another file ('" << value
                                       << "') is not supported; save the sequence as one file");
      data_follows = true;
      break;
    }
    fields[key] = value;
  }
  BS_VERIFY(data_follows, file << ": MetaImage header without 'ElementDataFile = LOCAL' "
                                  "(truncated or not a sequence file)");
  const auto field = [&](const std::string& key) -> const std::string& {
    const auto it = fields.find(key);
    BS_VERIFY(it != fields.end(), file << ": the header lacks '" << key << "'");
    return it->second;
  };
  const auto has = [&](const std::string& key) { return fields.count(key) > 0; };
  BS_VERIFY(!has("NDims") || field("NDims") == "3",
            file << ": NDims " << field("NDims") << " (a sequence of 2-D frames has 3)");
  const std::vector<double> dims = parse_numbers(field("DimSize"), file, "DimSize");
  BS_VERIFY(dims.size() == 3 && dims[0] >= 1 && dims[1] >= 1 && dims[2] >= 0 && dims[0] < 1e6 &&
                dims[1] < 1e6 && dims[2] < 1e7,
            file << ": DimSize '" << field("DimSize") << "' is not columns rows frames");
  h.columns = int(dims[0]);
  h.rows = int(dims[1]);
  h.frames = std::size_t(dims[2]);
  BS_VERIFY(!has("ElementNumberOfChannels") || field("ElementNumberOfChannels") == "1",
            file << ": " << field("ElementNumberOfChannels")
                 << " channels per pixel (colour video); a grey-scale sequence is needed");
  BS_VERIFY(
      !has("BinaryDataByteOrderMSB") || lower_case(field("BinaryDataByteOrderMSB")) == "false",
      file << ": big-endian pixel data is not supported");
  h.type = element_type(field("ElementType"), file);
  if (has("CompressedData") && lower_case(field("CompressedData")) == "true")
    h.packing = SequenceHeader::Packing::ZLIB;
  if (has("UltrasoundImageOrientation")) h.orientation = field("UltrasoundImageOrientation");
  return h;
}

ElementType nrrd_type(const std::string& name, const std::string& file) {
  const std::string t = lower_case(name);
  for (const auto& [names, metaimage] :
       std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"uchar", "unsigned char", "uint8", "uint8_t"}, "MET_UCHAR"},
           {{"signed char", "int8", "int8_t"}, "MET_CHAR"},
           {{"ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"}, "MET_USHORT"},
           {{"short", "short int", "signed short", "signed short int", "int16", "int16_t"},
            "MET_SHORT"},
           {{"uint", "unsigned int", "uint32", "uint32_t"}, "MET_UINT"},
           {{"int", "signed int", "int32", "int32_t"}, "MET_INT"},
           {{"float"}, "MET_FLOAT"},
           {{"double"}, "MET_DOUBLE"}})
    if (std::find(names.begin(), names.end(), t) != names.end())
      return element_type(metaimage, file);
  BS_THROW(file << ": unsupported NRRD type '" << name << "'");
}

/// PLUS's NRRD sequence (vtkPlusNrrdSequenceIO): NRRD fields, frame fields and the image
/// orientation as key/value pairs (`key:=value`), axes "domain domain [domain] list".
SequenceHeader nrrd_header(std::istream& in, const std::string& file) {
  SequenceHeader h;
  std::map<std::string, std::string> nrrd;
  std::string line;
  BS_VERIFY(std::getline(in, line) && line.rfind("NRRD000", 0) == 0,
            file << ": not a NRRD file (no NRRD000x magic)");
  bool ended = false;
  constexpr std::size_t max_header_lines = 5'000'000;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    BS_VERIFY(n < max_header_lines, file << ": NRRD header does not end");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      ended = true;
      break;
    }
    if (line[0] == '#') continue;
    if (const auto kv = line.find(":="); kv != std::string::npos) {
      h.fields[std::string(trim(line.substr(0, kv)))] = std::string(trim(line.substr(kv + 2)));
      continue;
    }
    const auto colon = line.find(':');
    BS_VERIFY(colon != std::string::npos,
              file << ": bad NRRD header line " << n + 1 << " '" << line.substr(0, 60) << "'");
    nrrd[lower_case(std::string(trim(line.substr(0, colon))))] =
        std::string(trim(line.substr(colon + 1)));
  }
  BS_VERIFY(ended, file << ": NRRD header ends without data (truncated file)");
  const auto field = [&](const std::string& key) -> const std::string& {
    const auto it = nrrd.find(key);
    BS_VERIFY(it != nrrd.end(), file << ": the NRRD header lacks '" << key << "'");
    return it->second;
  };
  BS_VERIFY(!nrrd.count("data file") && !nrrd.count("datafile"),
            file << ": pixel data in another file is not supported; save the sequence as one file");
  h.type = nrrd_type(field("type"), file);
  const std::vector<double> sizes = parse_numbers(field("sizes"), file, "sizes");
  std::istringstream kin(field("kinds"));
  std::vector<std::string> kinds;
  for (std::string k; kin >> k;) kinds.push_back(lower_case(k));
  BS_VERIFY(kinds.size() == sizes.size() && (sizes.size() == 3 || sizes.size() == 4),
            file << ": NRRD sizes '" << field("sizes") << "' and kinds '" << field("kinds")
                 << "' are not a sequence of 2-D frames");
  std::vector<double> domain;
  double frames = -1;
  for (std::size_t a = 0; a < kinds.size(); ++a) {
    BS_VERIFY(sizes[a] >= 0 && sizes[a] < 1e7, file << ": NRRD size " << sizes[a]);
    if (kinds[a] == "domain" || kinds[a] == "space")
      domain.push_back(sizes[a]);
    else if (kinds[a] == "list" || kinds[a] == "time")
      frames = sizes[a];
    else
      BS_VERIFY((kinds[a] == "vector" || kinds[a] == "scalar") && sizes[a] == 1,
                file << ": NRRD axis of kind '" << kinds[a] << "' and size " << sizes[a]
                     << "; a grey-scale sequence is needed");
  }
  BS_VERIFY(frames >= 0 && (domain.size() == 2 || (domain.size() == 3 && domain[2] == 1)) &&
                domain[0] >= 1 && domain[1] >= 1 && domain[0] < 1e6 && domain[1] < 1e6,
            file << ": NRRD sizes '" << field("sizes") << "' with kinds '" << field("kinds")
                 << "' are not columns rows [1] frames");
  h.columns = int(domain[0]);
  h.rows = int(domain[1]);
  h.frames = std::size_t(frames);
  BS_VERIFY(!nrrd.count("endian") || lower_case(nrrd["endian"]) == "little" || h.type.bytes == 1,
            file << ": big-endian pixel data is not supported");
  const std::string encoding = lower_case(field("encoding"));
  if (encoding == "gzip" || encoding == "gz")
    h.packing = SequenceHeader::Packing::GZIP;
  else
    BS_VERIFY(encoding == "raw",
              file << ": NRRD encoding '" << encoding << "' is not supported (raw or gzip)");
  for (const char* key : {"ultrasound image orientation", "UltrasoundImageOrientation"})
    if (h.fields.count(key)) h.orientation = h.fields[key];
  return h;
}

}  // namespace

bool is_plus_sequence(const std::filesystem::path& path) {
  std::string name = path.filename().string();
  for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));
  const auto ends = [&](const std::string& tail) {
    return name.size() > tail.size() &&
           name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
  };
  return ends(".seq.mha") || ends(".seq.nrrd");
}

PlusSequence read_plus_sequence(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path, std::ios::binary);
  BS_VERIFY(in.is_open(), file << ": cannot open (no such file, or not readable)");
  std::string name = lower_case(path.filename().string());
  const bool nrrd = name.size() > 5 && name.compare(name.size() - 5, 5, ".nrrd") == 0;
  SequenceHeader h = nrrd ? nrrd_header(in, file) : metaimage_header(in, file);
  const auto& fields = h.fields;
  PlusSequence seq;
  seq.columns = h.columns;
  seq.rows = h.rows;
  seq.orientation_in_file = h.orientation;
  const std::size_t count = h.frames;
  const ElementType type = h.type;
  const std::string& o = seq.orientation_in_file;
  BS_VERIFY((o.size() == 2 || (o.size() == 3 && (o[2] == 'A' || o[2] == 'D'))) &&
                (o[0] == 'M' || o[0] == 'U') && (o[1] == 'F' || o[1] == 'N'),
            file << ": UltrasoundImageOrientation '" << o
                 << "' is not one of MF, MN, UF, UN (the first two letters)");

  // Frames' fields.
  seq.frames.resize(count);
  for (std::size_t f = 0; f < count; ++f) {
    char prefix[32];
    std::snprintf(prefix, sizeof prefix, "Seq_Frame%04zu_", f);
    const std::string p = prefix;
    SequenceFrame& frame = seq.frames[f];
    for (auto it = fields.lower_bound(p); it != fields.end() && it->first.rfind(p, 0) == 0; ++it) {
      const std::string field_name = it->first.substr(p.size());
      const std::string where = it->first;
      if (field_name == "Timestamp") {
        const auto v = parse_numbers(it->second, file, where);
        BS_VERIFY(v.size() == 1, file << ": " << where << " is not one number");
        frame.timestamp = v[0];
      } else if (field_name == "ImageStatus") {
        frame.image_ok = it->second == "OK";
      } else if (field_name.size() > 9 &&
                 field_name.compare(field_name.size() - 9, 9, "Transform") == 0) {
        const auto status = fields.find(it->first + "Status");
        const bool ok = status == fields.end() || status->second == "OK";
        const std::string transform = field_name.substr(0, field_name.size() - 9);
        if (ok)
          frame.transforms[transform] =
              matrix_of(parse_numbers(it->second, file, where), file, where);
        else
          frame.invalid.push_back(transform);
      }
    }
  }

  // Pixels: the claimed size is checked against the file before anything is allocated (raw:
  // the bytes left; compressed: deflate's largest ratio, 1032:1).
  const std::size_t per_frame = std::size_t(seq.columns) * std::size_t(seq.rows);
  const double claimed = double(per_frame) * double(count) * double(type.bytes);
  const auto start = in.tellg();
  in.seekg(0, std::ios::end);
  const double left = double(in.tellg() - start);
  in.seekg(start);
  if (h.packing == SequenceHeader::Packing::RAW)
    BS_VERIFY(claimed <= left, file << ": truncated pixel data (" << left << " of " << claimed
                                    << " bytes the header claims)");
  else
    BS_VERIFY(claimed <= 1032.0 * left + 1024.0,
              file << ": the header claims " << claimed << " bytes of pixels from " << left
                   << " compressed bytes, more than deflate can hold (corrupt header)");
  BS_VERIFY(claimed < double(1ULL << 34), file << ": the header claims " << claimed
                                               << " bytes of pixels, more than this tool reads");
  const std::size_t bytes = std::size_t(claimed);
  std::vector<unsigned char> raw(bytes);
  if (h.packing == SequenceHeader::Packing::RAW) {
    in.read(reinterpret_cast<char*>(raw.data()), std::streamsize(bytes));
    BS_VERIFY(std::size_t(in.gcount()) == bytes,
              file << ": truncated pixel data (" << in.gcount() << " of " << bytes << " bytes)");
  } else {
    std::vector<unsigned char> packed((std::istreambuf_iterator<char>(in)),
                                      std::istreambuf_iterator<char>());
    z_stream z{};
    // zlib (MetaImage's CompressedData) or gzip (NRRD's encoding): 15 + 32 detects either.
    BS_VERIFY(inflateInit2(&z, 15 + 32) == Z_OK, file << ": cannot start decompression");
    z.next_in = packed.data();
    z.avail_in = uInt(std::min<std::size_t>(packed.size(), UINT32_MAX));
    z.next_out = raw.data();
    std::size_t produced = 0;
    int status = Z_OK;
    while (produced < bytes && status == Z_OK) {
      z.avail_out = uInt(std::min<std::size_t>(bytes - produced, UINT32_MAX));
      const auto before = z.total_out;
      status = inflate(&z, Z_NO_FLUSH);
      produced += std::size_t(z.total_out - before);
      if (status == Z_BUF_ERROR && z.avail_in == 0) break;
    }
    inflateEnd(&z);
    BS_VERIFY(produced == bytes && (status == Z_OK || status == Z_STREAM_END),
              file << ": corrupt or truncated compressed pixel data (" << produced << " of "
                   << bytes << " bytes)");
  }
  // Turned to MF: U mirrors the columns, N the rows.
  const bool flip_x = o[0] == 'U', flip_y = o[1] == 'N';
  seq.pixels.resize(per_frame * count);
  for (std::size_t f = 0; f < count; ++f)
    for (int r = 0; r < seq.rows; ++r)
      for (int c = 0; c < seq.columns; ++c) {
        const std::size_t src =
            f * per_frame + std::size_t(r) * std::size_t(seq.columns) + std::size_t(c);
        const int rr = flip_y ? seq.rows - 1 - r : r, cc = flip_x ? seq.columns - 1 - c : c;
        seq.pixels[f * per_frame + std::size_t(rr) * std::size_t(seq.columns) + std::size_t(cc)] =
            type.to_float(&raw[src * std::size_t(type.bytes)]);
      }
  return seq;
}

std::vector<std::optional<Eigen::Matrix4d>> image_to_world(
    const PlusSequence& sequence, const std::string& file,
    const std::optional<Eigen::Matrix4d>& calibration, const std::string& image_to) {
  std::vector<std::optional<Eigen::Matrix4d>> out(sequence.frames.size());
  std::set<std::string> names;
  int placed = 0;
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    const SequenceFrame& frame = sequence.frames[f];
    for (const auto& [name, m] : frame.transforms) names.insert(name);
    for (const auto& name : frame.invalid) names.insert(name);
    if (!frame.image_ok) continue;
    const auto get = [&](const std::string& name) -> const Eigen::Matrix4d* {
      const auto it = frame.transforms.find(name);
      return it == frame.transforms.end() ? nullptr : &it->second;
    };
    std::optional<Eigen::Matrix4d> m;
    if (!image_to.empty()) {
      if (const auto* t = get(image_to)) m = *t;
    } else if (calibration) {
      for (const char* probe : {"ProbeToReference", "ProbeToTracker"})
        if (const auto* t = get(probe)) {
          m = (*t) * (*calibration);
          break;
        }
    } else {
      for (const char* image : {"ImageToReference", "ImageToTracker"})
        if (const auto* t = get(image)) {
          m = *t;
          break;
        }
      // Recordings that carry the calibration in every frame (ImageToProbeTransform).
      if (const auto* c = get("ImageToProbe"); !m && c)
        for (const char* probe : {"ProbeToReference", "ProbeToTracker"})
          if (const auto* t = get(probe)) {
            m = (*t) * (*c);
            break;
          }
    }
    if (m) {
      out[f] = m;
      ++placed;
    }
  }
  if (placed == 0 && !sequence.frames.empty()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n + "Transform";
    BS_THROW(file << ": no frame can be placed: "
                  << (!image_to.empty() ? "no valid " + image_to + "Transform"
                      : calibration     ? std::string("no valid ProbeToReference or ProbeToTracker "
                                                          "transform")
                                        : std::string("no valid ImageToReference or "
                                                          "ImageToTracker transform (give "
                                                          "--calibration with a ProbeTo* one)"))
                  << "; the file has " << (list.empty() ? "no transforms" : list));
  }
  return out;
}

Eigen::Matrix4d read_matrix_file(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path);
  BS_VERIFY(in.is_open(), file << ": cannot open (no such file, or not readable)");
  std::ostringstream text;
  text << in.rdbuf();
  BS_VERIFY(text.str().size() < 65536, file << ": too long for a 4x4 matrix");
  return matrix_of(parse_numbers(text.str(), file, "matrix"), file, "matrix");
}

}  // namespace brainshift::imaging
