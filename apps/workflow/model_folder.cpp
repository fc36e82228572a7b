#include "apps/workflow/model_folder.hpp"

#include "core/error.hpp"
#include "core/hash.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/header_checks.hpp"
#include "imaging/io/image_frame.hpp"
#include "imaging/io/output_guard.hpp"

#include <fcntl.h>
#include <fstream>
#include <random>
#include <stdio.h>  // renameat2
#include <system_error>

namespace brainshift::workflow {

std::uint64_t file_hash(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  BS_VERIFY(in.good(), path.string() << ": cannot read");
  std::uint64_t h = core::fnv1a_offset;
  char buf[1 << 16];
  while (in) {
    in.read(buf, sizeof buf);
    h = core::fnv1a(buf, static_cast<std::size_t>(in.gcount()), h);
  }
  return h;
}

nlohmann::json grid_to_json(const imaging::ImageGeometry& g) {
  nlohmann::json j;
  j["size"] = {g.size[0], g.size[1], g.size[2]};
  j["origin_mm"] = {g.origin[0], g.origin[1], g.origin[2]};
  j["spacing_mm"] = {g.spacing[0], g.spacing[1], g.spacing[2]};
  j["direction"] = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    j["direction"].push_back({g.direction(r, 0), g.direction(r, 1), g.direction(r, 2)});
  return j;
}

imaging::ImageGeometry grid_from_json(const nlohmann::json& j) {
  imaging::ImageGeometry g;
  for (int k = 0; k < 3; ++k) {
    g.size[k] = j.at("size").at(k).get<int>();
    g.origin[k] = j.at("origin_mm").at(k).get<double>();
    g.spacing[k] = j.at("spacing_mm").at(k).get<double>();
    for (int c = 0; c < 3; ++c) g.direction(k, c) = j.at("direction").at(k).at(c).get<double>();
  }
  return g;
}

bool same_grid(const imaging::ImageGeometry& a, const imaging::ImageGeometry& b) {
  return a.size == b.size && (a.origin - b.origin).cwiseAbs().maxCoeff() < 1e-3 &&
         (a.spacing - b.spacing).cwiseAbs().maxCoeff() < 1e-6 &&
         (a.direction - b.direction).cwiseAbs().maxCoeff() < 1e-6;
}

void grid_bounds(const imaging::ImageGeometry& g, Vector3d& lo, Vector3d& hi) {
  lo = Vector3d::Constant(1e300);
  hi = Vector3d::Constant(-1e300);
  for (int c = 0; c < 8; ++c) {
    const Vector3d ijk((c & 1) ? g.size[0] - 1 : 0, (c & 2) ? g.size[1] - 1 : 0,
                       (c & 4) ? g.size[2] - 1 : 0);
    const Vector3d p = g.index_to_world(ijk);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
}

bool grid_overlaps(const imaging::ImageGeometry& g, const Vector3d& lo, const Vector3d& hi,
                   double margin) {
  Vector3d glo, ghi;
  grid_bounds(g, glo, ghi);
  return ((glo.array() <= hi.array() + margin) && (ghi.array() >= lo.array() - margin)).all();
}

LoadedModel load_model(const std::filesystem::path& dir) {
  const std::filesystem::path manifest_path = dir / "model.json";
  std::error_code ec;
  BS_VERIFY(std::filesystem::is_directory(dir, ec),
            dir.string() << ": no such model folder (run brainshift prepare)");
  BS_VERIFY(
      std::filesystem::exists(manifest_path, ec),
      dir.string() << ": not a brainshift model folder (no model.json; run brainshift prepare)");
  LoadedModel m;
  try {
    std::ifstream in(manifest_path);
    m.manifest = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    BS_VERIFY(false, manifest_path.string()
                         << ": unreadable manifest (not valid JSON at byte " << e.byte << ")");
  } catch (const nlohmann::json::exception&) {  // e.g. a number beyond double's range
    BS_VERIFY(false, manifest_path.string() << ": unreadable manifest (a number out of range)");
  }
  BS_VERIFY(m.manifest.is_object(), manifest_path.string()
                                        << ": not a brainshift model manifest (not a JSON object)");
  const auto text = [&](const char* key) {
    const auto it = m.manifest.find(key);
    return it != m.manifest.end() && it->is_string() ? it->get<std::string>() : std::string();
  };
  BS_VERIFY(text("format") == model_format, manifest_path.string()
                                                << ": not a brainshift model (format '"
                                                << text("format").substr(0, 40) << "')");
  const auto version_it = m.manifest.find("version");
  const int version = version_it != m.manifest.end() && version_it->is_number_integer()
                          ? version_it->get<int>()
                          : 0;
  BS_VERIFY(version == model_version, manifest_path.string()
                                          << ": model version " << version
                                          << ", this brainshift reads version " << model_version
                                          << "; run brainshift prepare again");
  try {
    m.preop_grid = grid_from_json(m.manifest.at("preop_grid"));
  } catch (const nlohmann::json::exception&) {
    BS_VERIFY(false, manifest_path.string()
                         << ": bad 'preop_grid' (needs size, origin_mm, spacing_mm: 3 numbers "
                            "each; direction: 3 rows of 3)");
  }
  // The result fields are allocated on this grid (3 floats a voxel, several fields).
  imaging::verify_geometry(m.preop_grid, manifest_path.string() + ": preop_grid");
  BS_VERIFY(12.0 * m.preop_grid.size.cast<double>().prod() <= imaging::max_volume_bytes(),
            manifest_path.string() << ": preop_grid claims " << m.preop_grid.size.transpose()
                                   << " voxels, over BRAINSHIFT_MAX_VOLUME_GB for its fields");
  m.scene = workflow::read_scene(dir / "scene.json");
  return m;
}

void verify_output_folder(const std::filesystem::path& dir) {
  const std::filesystem::path target = std::filesystem::absolute(dir).lexically_normal();
  std::error_code ec;
  BS_VERIFY(!std::filesystem::exists(target, ec) || std::filesystem::is_directory(target, ec),
            dir.string() << ": exists and is not a folder");
  std::string probe = ".";
  probe.append(target.filename().string()).append(".check");
  try {
    imaging::verify_writable(target.parent_path() / probe);
  } catch (const Error&) {
    BS_VERIFY(false, dir.string() << ": cannot be written (its folder "
                                  << target.parent_path().string()
                                  << " does not exist or is not writable)");
  }
}

void write_folder_atomically(const std::filesystem::path& dir,
                             const std::function<void(const std::filesystem::path&)>& fill) {
  const std::filesystem::path target = std::filesystem::absolute(dir).lexically_normal();
  const std::filesystem::path parent = target.parent_path();
  std::error_code ec;
  imaging::resume_interruption();  // a signal held since the previous output ends the run now
  verify_output_folder(dir);
  std::mt19937_64 rng(std::random_device{}());
  const std::string tag = std::to_string(rng() % 1000000000ULL);
  // (appended piecewise: GCC 12 warns falsely (-Wrestrict) on "." + string + ...)
  std::string base = ".";
  base.append(target.filename().string());
  const std::filesystem::path tmp = parent / (base + ".tmp-" + tag);
  std::filesystem::create_directory(tmp, ec);
  BS_VERIFY(!ec, dir.string() << ": cannot create a temporary folder: " << ec.message());
  const imaging::TemporaryGuard guard(tmp);  // removed if a signal ends the run meanwhile
  try {
    fill(tmp);
  } catch (...) {
    std::filesystem::remove_all(tmp, ec);
    throw;
  }
  // From here the result is put in place: a signal no longer interrupts (output_guard.hpp), so a
  // run ended by a signal has left `dir` as it was, and one that was not has written it whole.
  const imaging::CommitSection commit(true);
  // An existing folder is exchanged with the new one in one step (renameat2 RENAME_EXCHANGE):
  // `dir` is never absent or partial, and the old content, now under the temporary name, goes.
  if (std::filesystem::exists(target, ec)) {
    if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) {
      std::filesystem::remove_all(tmp, ec);
      return;
    }
    // A file system without the exchange: move the old folder aside first.
    const std::filesystem::path old = parent / (base + ".old-" + tag);
    const imaging::TemporaryGuard old_guard(old);
    std::filesystem::rename(target, old, ec);
    BS_VERIFY(!ec, dir.string() << ": cannot replace the existing folder: " << ec.message());
    std::filesystem::rename(tmp, target, ec);
    if (ec) {
      std::filesystem::rename(old, target, ec);
      std::filesystem::remove_all(tmp, ec);
      BS_VERIFY(false, dir.string() << ": cannot move the result into place");
    }
    std::filesystem::remove_all(old, ec);
    return;
  }
  std::filesystem::rename(tmp, target, ec);
  if (ec) {
    std::filesystem::remove_all(tmp, ec);
    BS_VERIFY(false, dir.string() << ": cannot move the result into place");
  }
}

}  // namespace brainshift::workflow
