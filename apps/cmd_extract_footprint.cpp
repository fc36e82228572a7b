#include "cmd_extract_footprint.hpp"

#include "apps/workflow/intraop_footprint.hpp"
#include "apps/workflow/progress.hpp"
#include "core/config.hpp"
#include "core/error.hpp"
#include "imaging/footprint/footprint_io.hpp"
#include "imaging/io/atomic_write.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <ostream>
#include <sstream>

namespace brainshift::apps {
namespace {

/// "X,Y,Z" → a unit vector. \throws brainshift::Error (one line) for anything but three finite
/// numbers separated by commas, or a zero vector.
Vector3d parse_direction(const std::string& text) {
  Vector3d v;
  std::size_t begin = 0;
  bool ok = true;
  for (int a = 0; a < 3 && ok; ++a) {
    const std::size_t end = a < 2 ? text.find(',', begin) : text.size();
    ok = end != std::string::npos && end > begin;
    if (!ok) break;
    const std::string token = text.substr(begin, end - begin);
    char* stop = nullptr;
    v[a] = std::strtod(token.c_str(), &stop);
    ok = stop != token.c_str() && *stop == '\0' && std::isfinite(v[a]);
    begin = end + 1;
  }
  BS_VERIFY(ok, "--probe-direction: expected X,Y,Z (three numbers), got '" << text << "'");
  BS_VERIFY(v.norm() > 1e-9, "--probe-direction: the direction " << text << " has zero length");
  return v.normalized();
}

}  // namespace

CLI::App* add_extract_footprint_command(CLI::App& extract, ExtractFootprintArgs& args) {
  CLI::App* c = extract.add_subcommand(
      "footprint", "Probe footprint (contact points and normals) of a B-mode volume");
  c->add_option("--bmode", args.bmode,
                "B-mode volume (0 outside the swept region); any grid orientation")
      ->required();
  c->add_option("--probe-direction", args.probe_direction,
                "beam direction X,Y,Z (world RAS, from the probe into the tissue); default: "
                "estimated from the data");
  c->add_option("--out", args.out,
                "FOOTPRINT.vtp: points (RAS mm) with the point array 'normals' (into the tissue)")
      ->required();
  c->add_option("--report", args.report, "REPORT.json");
  return c;
}

int run_extract_footprint(const ExtractFootprintArgs& args, std::ostream& out) {
  const workflow::Progress progress("extract footprint");
  std::optional<Vector3d> direction;
  if (args.probe_direction) direction = parse_direction(*args.probe_direction);
  imaging::verify_writable(args.out);
  if (args.report) imaging::verify_writable(*args.report);
  progress.stage("reading " + args.bmode.string() + " and finding the contact band");
  const workflow::IntraopFootprint f = workflow::footprint_from_bmode(args.bmode, direction);
  BS_VERIFY(f.found, args.bmode.string()
                         << ": "
                         << f.report.value("message", std::string("no contact band found")));
  nlohmann::json report = f.report;
  report["seconds"] = progress.seconds();
  imaging::write_footprint_vtp(args.out, f.points, f.normals);
  if (args.report) {
    imaging::write_atomically(*args.report, [&](const std::filesystem::path& tmp) {
      std::ofstream o(tmp);
      o << report.dump(2) << '\n';
      BS_VERIFY(o.good(), "cannot write " << tmp.string());
    });
  }
  const auto& d = report["probe_direction"];
  out << "footprint of " << args.bmode.string() << ": " << f.points.rows() << " points over "
      << report["width_mm"].get<double>() << " x " << report["elevation_mm"].get<double>()
      << " mm, contrast " << report["contrast"].get<double>() << ", probe direction ("
      << d[0].get<double>() << ", " << d[1].get<double>() << ", " << d[2].get<double>() << ") "
      << report["direction_source"].get<std::string>()
      << (f.warnings.empty() ? "" : ", " + std::to_string(f.warnings.size()) + " warning(s)")
      << " -> " << args.out.string() << "\n";
  return 0;
}

}  // namespace brainshift::apps
