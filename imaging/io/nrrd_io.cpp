#include "imaging/io/nrrd_io.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "imaging/io/header_checks.hpp"
#include "imaging/io/image_frame.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

static_assert(std::endian::native == std::endian::little, "NRRD I/O assumes a little-endian host");

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

/// Element type of a NRRD `type` field: size in bytes and a converter to float.
struct ElementType {
  int bytes = 0;
  float (*to_float)(const unsigned char*) = nullptr;
};

template <typename T>
float convert(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return static_cast<float>(v);
}

ElementType element_type(const std::string& name, const std::string& file) {
  static const std::map<std::string, ElementType> types = {
      {"int8", {1, convert<std::int8_t>}},
      {"signed char", {1, convert<std::int8_t>}},
      {"int8_t", {1, convert<std::int8_t>}},
      {"char", {1, convert<std::int8_t>}},
      {"uchar", {1, convert<std::uint8_t>}},
      {"unsigned char", {1, convert<std::uint8_t>}},
      {"uint8", {1, convert<std::uint8_t>}},
      {"uint8_t", {1, convert<std::uint8_t>}},
      {"short", {2, convert<std::int16_t>}},
      {"short int", {2, convert<std::int16_t>}},
      {"signed short", {2, convert<std::int16_t>}},
      {"int16", {2, convert<std::int16_t>}},
      {"int16_t", {2, convert<std::int16_t>}},
      {"ushort", {2, convert<std::uint16_t>}},
      {"unsigned short", {2, convert<std::uint16_t>}},
      {"uint16", {2, convert<std::uint16_t>}},
      {"uint16_t", {2, convert<std::uint16_t>}},
      {"int", {4, convert<std::int32_t>}},
      {"signed int", {4, convert<std::int32_t>}},
      {"int32", {4, convert<std::int32_t>}},
      {"int32_t", {4, convert<std::int32_t>}},
      {"uint", {4, convert<std::uint32_t>}},
      {"unsigned int", {4, convert<std::uint32_t>}},
      {"uint32", {4, convert<std::uint32_t>}},
      {"uint32_t", {4, convert<std::uint32_t>}},
      {"float", {4, convert<float>}},
      {"double", {8, convert<double>}}};
  const auto it = types.find(name);
  BS_VERIFY(it != types.end(), file << ": unsupported NRRD type '" << name << "'");
  return it->second;
}

/// Sign of each axis of a NRRD space relative to RAS.
Vector3d space_signs(const std::string& space, const std::string& file) {
  if (space == "right-anterior-superior" || space == "RAS") return {1, 1, 1};
  if (space == "left-posterior-superior" || space == "LPS") return {-1, -1, 1};
  if (space == "left-anterior-superior" || space == "LAS") return {-1, 1, 1};
  BS_THROW(file << ": unsupported NRRD space '" << space
                << "' (supported: right-anterior-superior, left-posterior-superior, "
                   "left-anterior-superior)");
}

/// "(a,b,c)" → vector; "none" → NaN vector.
Vector3d parse_vector(const std::string& text, const std::string& file, const std::string& field) {
  if (trim(text) == "none") return Vector3d::Constant(std::nan(""));
  std::string s = text;
  std::replace_if(
      s.begin(), s.end(), [](char c) { return c == '(' || c == ')' || c == ','; }, ' ');
  std::istringstream in(s);
  Vector3d v;
  for (int a = 0; a < 3; ++a) {
    std::string token;
    char* end = nullptr;
    const bool read = static_cast<bool>(in >> token);
    if (read) v[a] = std::strtod(token.c_str(), &end);  // strtod: also "nan" and "inf"
    BS_VERIFY(read && end != nullptr && *end == '\0',
              file << ": cannot parse NRRD field '" << field << "' vector '" << text << "'");
  }
  return v;
}

/// The vectors of "space directions" or "measurement frame": "(a,b,c) (d,e,f) none ...".
std::vector<Vector3d> parse_vectors(const std::string& text, const std::string& file,
                                    const char* field = "space directions") {
  std::vector<Vector3d> out;
  std::istringstream in(text);
  for (std::string token; in >> token;) {
    if (token == "none") {
      out.push_back(Vector3d::Constant(std::nan("")));
      continue;
    }
    while (token.find(')') == std::string::npos) {
      std::string more;
      BS_VERIFY(static_cast<bool>(in >> more),
                file << ": cannot parse NRRD " << field << " '" << text << "'");
      token += more;
    }
    out.push_back(parse_vector(token, file, field));
  }
  return out;
}

/// A number of a header field, or a one-line error naming the field.
template <typename T>
T number(const std::string& text, const std::string& file, const std::string& field) {
  std::istringstream in(text);
  T value{};
  BS_VERIFY(static_cast<bool>(in >> value),
            file << ": NRRD field '" << field << "' has a bad number '" << text << "'");
  return value;
}

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

/// Inflates gzip data; throws when the stream is corrupt or yields other than `expected` bytes.
std::vector<unsigned char> gunzip(const std::vector<unsigned char>& in, std::size_t expected,
                                  const std::string& file) {
  std::vector<unsigned char> out(expected);
  z_stream z{};
  BS_VERIFY(inflateInit2(&z, 15 + 32) == Z_OK, file << ": cannot initialise zlib");
  z.next_in = const_cast<unsigned char*>(in.data());
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  const int status = inflate(&z, Z_FINISH);
  const std::size_t produced = z.total_out;
  inflateEnd(&z);
  BS_VERIFY(status == Z_STREAM_END || (status == Z_BUF_ERROR && produced == expected),
            file << ": corrupt or truncated gzip data (" << produced << " of " << expected
                 << " bytes decoded)");
  BS_VERIFY(produced == expected,
            file << ": gzip data holds " << produced << " bytes, expected " << expected);
  return out;
}

template <typename T>
void write_nrrd_impl(const std::filesystem::path& path, const Volume<T>& volume, NrrdSpace space,
                     const char* type_name,
                     const std::vector<std::pair<std::string, std::string>>& key_values) {
  const ImageGeometry& g = volume.geometry;
  const Vector3d signs = space == NrrdSpace::LPS ? Vector3d(-1, -1, 1) : Vector3d(1, 1, 1);
  const Vector3d origin = signs.cwiseProduct(g.origin);
  const Matrix3d axes = signs.asDiagonal() * g.direction * g.spacing.asDiagonal();
  const bool vector = std::is_same_v<T, float> && volume.components == 3;
  const bool multi = volume.components > 1;

  std::ostringstream h;
  h << std::setprecision(17);
  h << "NRRD0004\n# written by brainshift\ntype: " << type_name
    << "\ndimension: " << (multi ? 4 : 3) << "\nspace: "
    << (space == NrrdSpace::LPS ? "left-posterior-superior" : "right-anterior-superior")
    << "\nsizes:";
  if (multi) h << ' ' << volume.components;
  h << ' ' << g.size[0] << ' ' << g.size[1] << ' ' << g.size[2] << "\nspace directions:";
  if (multi) h << " none";
  for (int a = 0; a < 3; ++a)
    h << " (" << axes(0, a) << ',' << axes(1, a) << ',' << axes(2, a) << ')';
  h << "\nkinds:";
  if (multi) h << (vector ? " vector" : " list");
  h << " domain domain domain\nendian: little\nencoding: raw\nspace origin: (" << origin[0] << ','
    << origin[1] << ',' << origin[2] << ")\n";
  // The vectors' components are in `space` itself (Slicer and ITK read no measurement frame as
  // the identity too; stating it leaves no reader guessing).
  if (vector) h << "measurement frame: (1,0,0) (0,1,0) (0,0,1)\n";
  for (const auto& [key, value] : key_values) {
    BS_VERIFY(!key.empty() && key.find(":=") == std::string::npos &&
                  key.find('\n') == std::string::npos && value.find('\n') == std::string::npos,
              path.string() << ": bad NRRD key/value pair '" << key << "'");
    h << key << ":=" << value << '\n';
  }
  h << '\n';

  // The voxels in blocks of 1 MiB (whole vectors), LPS components negated block by block: no
  // copy of the whole volume (a displacement field at the MRI's size is 100 MB).
  const bool flip = vector && space == NrrdSpace::LPS;
  std::ofstream out(path, std::ios::binary);
  const std::string header = h.str();
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  constexpr std::size_t block = (std::size_t(1) << 20) / (3 * sizeof(T)) * 3;
  std::vector<T> buffer;
  for (std::size_t b = 0; b < volume.data.size() && out.good(); b += block) {
    const std::size_t n = std::min(block, volume.data.size() - b);
    const T* src = volume.data.data() + b;
    if (flip) {
      buffer.assign(src, src + n);
      for (std::size_t v = 0; v + 2 < n; v += 3) {
        buffer[v] = -buffer[v];
        buffer[v + 1] = -buffer[v + 1];
      }
      src = buffer.data();
    }
    out.write(reinterpret_cast<const char*>(src), static_cast<std::streamsize>(n * sizeof(T)));
  }
  out.close();
  BS_VERIFY(out.good(), path.string() << ": cannot write the NRRD file");
}

}  // namespace

VolumeF read_nrrd(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path, std::ios::binary);
  BS_VERIFY(in.is_open(), file << ": cannot open");
  std::string line;
  BS_VERIFY(std::getline(in, line) && line.rfind("NRRD000", 0) == 0,
            file << ": not a NRRD file (no NRRD000x magic)");
  std::map<std::string, std::string> fields;
  constexpr int max_header_lines = 10000;  // a header longer than this is not a NRRD header
  int lines = 0;
  while (std::getline(in, line)) {
    BS_VERIFY(++lines < max_header_lines, file << ": NRRD header does not end");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos) continue;  // key/value pairs: not needed
    const auto colon = line.find(": ");
    BS_VERIFY(colon != std::string::npos, file << ": bad NRRD header line '" << line << "'");
    fields[line.substr(0, colon)] = trim(line.substr(colon + 2));
  }
  BS_VERIFY(in.good(), file << ": NRRD header ends without data (truncated file)");
  const auto field = [&](const std::string& key) -> std::string {
    const auto it = fields.find(key);
    BS_VERIFY(it != fields.end(), file << ": NRRD header lacks the required field '" << key << "'");
    return it->second;
  };
  const auto has = [&](const std::string& key) { return fields.count(key) > 0; };
  BS_VERIFY(!has("data file") && !has("datafile"),
            file << ": detached NRRD data (.nhdr) is not supported; save as a single .nrrd");
  for (const char* key : {"byte skip", "line skip"})
    BS_VERIFY(!has(key) || number<int>(fields[key], file, key) == 0,
              file << ": NRRD '" << key << "' is not supported");

  const ElementType type = element_type(field("type"), file);
  const int dimension = number<int>(field("dimension"), file, "dimension");
  BS_VERIFY(dimension == 3 || dimension == 4,
            file << ": NRRD dimension " << dimension << " is not supported (3 or 4)");
  std::vector<long long> sizes;
  for (const auto& w : words(field("sizes"))) sizes.push_back(number<long long>(w, file, "sizes"));
  BS_VERIFY(int(sizes.size()) == dimension,
            file << ": NRRD sizes has " << sizes.size() << " values, expected " << dimension);
  const int first_domain = dimension - 3;
  // The component axis: 1 (scalars), 3 (vectors), up to a 3×3 tensor's 9 in the files we
  // meet; 1024 bounds it well before the element count could overflow.
  BS_VERIFY(dimension == 3 || (sizes[0] >= 1 && sizes[0] <= 1024),
            file << ": NRRD component axis of size " << sizes[0] << " (expected 1 to 1024)");
  const int components = dimension == 4 ? int(sizes[0]) : 1;

  ImageGeometry g;
  for (int a = 0; a < 3; ++a) {
    BS_VERIFY(sizes[first_domain + a] >= 0 && sizes[first_domain + a] < (1LL << 31),
              file << ": bad NRRD size " << sizes[first_domain + a]);
    g.size[a] = int(sizes[first_domain + a]);
  }
  // A header that claims more than 2^36 elements (256 GiB of floats) is refused before anything
  // is allocated (a damaged or hostile header; the product below would also overflow).
  BS_VERIFY(double(g.size[0]) * double(g.size[1]) * double(g.size[2]) * double(components) <
                double(1LL << 36),
            file << ": NRRD sizes claim " << g.size[0] << "×" << g.size[1] << "×" << g.size[2]
                 << "×" << components << " elements, more than this tool reads");
  Vector3d signs(1, 1, 1);
  if (has("space")) {
    signs = space_signs(fields["space"], file);
    const std::vector<Vector3d> dirs = parse_vectors(field("space directions"), file);
    BS_VERIFY(int(dirs.size()) == dimension, file << ": NRRD space directions has " << dirs.size()
                                                  << " entries, expected " << dimension);
    BS_VERIFY(dimension == 3 || dirs[0].hasNaN(),
              file << ": the first axis of a 4-D NRRD must be the component axis (none)");
    for (int a = 0; a < 3; ++a) {
      const Vector3d& d = dirs[first_domain + a];
      g.spacing[a] = d.norm();
      g.direction.col(a) = d / g.spacing[a];
    }
    if (has("space origin")) g.origin = parse_vector(fields["space origin"], file, "space origin");
  } else {
    BS_VERIFY(!has("space dimension"),
              file << ": NRRD 'space dimension' without 'space' is not supported");
    logger().warn("{}: NRRD without 'space': taken as RAS with identity direction", file);
    if (has("spacings")) {
      const auto w = words(fields["spacings"]);
      BS_VERIFY(int(w.size()) == dimension,
                file << ": NRRD spacings has " << w.size() << " values, expected " << dimension);
      for (int a = 0; a < 3; ++a)
        g.spacing[a] = number<double>(w[first_domain + a], file, "spacings");
    }
  }
  g.origin = signs.cwiseProduct(g.origin);
  g.direction = signs.asDiagonal() * g.direction;
  verify_geometry(g, file);

  const std::size_t count = std::size_t(g.voxel_count()) * std::size_t(components);
  const std::size_t bytes = count * std::size_t(type.bytes);
  const std::string encoding = field("encoding");
  // What the header claims against the memory ceiling and the file, before any allocation.
  verify_claimed_bytes(file, double(bytes), double(in.tellg()), encoding != "raw");
  std::vector<unsigned char> raw;
  if (encoding == "raw") {
    raw.resize(bytes);
    in.read(reinterpret_cast<char*>(raw.data()), std::streamsize(bytes));
    BS_VERIFY(std::size_t(in.gcount()) == bytes,
              file << ": truncated NRRD data (" << in.gcount() << " of " << bytes << " bytes)");
  } else if (encoding == "gzip" || encoding == "gz") {
    const std::vector<unsigned char> packed((std::istreambuf_iterator<char>(in)),
                                            std::istreambuf_iterator<char>());
    raw = gunzip(packed, bytes, file);
  } else {
    BS_THROW(file << ": unsupported NRRD encoding '" << encoding << "' (raw or gzip)");
  }
  const bool big = has("endian") && fields["endian"] == "big";
  if (big && type.bytes > 1)
    for (std::size_t i = 0; i < count; ++i)
      std::reverse(raw.begin() + std::ptrdiff_t(i * type.bytes),
                   raw.begin() + std::ptrdiff_t((i + 1) * type.bytes));

  VolumeF volume(g, components);
  for (std::size_t i = 0; i < count; ++i) volume.data[i] = type.to_float(&raw[i * type.bytes]);
  if (components == 3) {
    // Vector components given in the measurement frame M (columns: its axes in the file's
    // space) are M v in that space; then the space's signs take them to RAS.
    Matrix3d to_ras = signs.asDiagonal();
    if (has("measurement frame")) {
      const std::vector<Vector3d> m =
          parse_vectors(fields["measurement frame"], file, "measurement frame");
      BS_VERIFY(m.size() == 3 && !m[0].hasNaN() && !m[1].hasNaN() && !m[2].hasNaN(),
                file << ": NRRD measurement frame must be three vectors");
      Matrix3d frame;
      for (int a = 0; a < 3; ++a) frame.col(a) = m[std::size_t(a)];
      BS_VERIFY(std::abs(frame.determinant()) > 1e-6,
                file << ": NRRD measurement frame is singular");
      to_ras = to_ras * frame;
    }
    for (std::size_t v = 0; v < count; v += 3) {
      const Vector3d x(volume.data[v], volume.data[v + 1], volume.data[v + 2]);
      const Vector3d y = to_ras * x;
      for (int c = 0; c < 3; ++c) volume.data[v + std::size_t(c)] = float(y[c]);
    }
  }
  return volume;
}

void write_nrrd(const std::filesystem::path& path, const VolumeF& volume, NrrdSpace space,
                const std::vector<std::pair<std::string, std::string>>& key_values) {
  write_nrrd_impl(path, volume, space, "float", key_values);
}

void write_nrrd(const std::filesystem::path& path, const LabelVolume& volume, NrrdSpace space) {
  write_nrrd_impl(path, volume, space, "uint8", {});
}

}  // namespace brainshift::imaging
