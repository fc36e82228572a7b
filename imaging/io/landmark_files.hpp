#pragma once
/// @file
/// @brief Landmark files as users have them: our CSV, MNI tag files (RESECT's expert landmarks),
/// 3D Slicer markups (.mrk.json) and Slicer's legacy fiducial lists (.fcsv). Every reader returns
/// world RAS millimetres; files in LPS (Slicer's default) are converted.
///
/// Formats, chosen by the file name's ending (case-insensitive):
/// - `.csv`: `id,x,y,z` (world RAS mm; csv.hpp).
/// - `.tag`: MNI tag point file (MINC world coordinates, RAS mm). After `Points =`, one point per
///   line: x y z (one volume) or x1 y1 z1 x2 y2 z2 (`Volumes = 2`), optionally followed by
///   weight, structure id, patient id and a quoted label; `;` ends the list. Ids: the label when
///   it is not empty, else the 1-based line number ("1", "2", ...). A two-volume file holds
///   pairs: `volume` picks the set (RESECT: the first is the MRI, the second the ultrasound).
/// - `.mrk.json`: Slicer markups JSON (any markup type's control points, all markups of the file
///   in order). Each markup's `coordinateSystem` is "LPS" (Slicer's default, also when absent) or
///   "RAS"; points whose `positionStatus` is "undefined" or "missing" are skipped. Ids: the
///   control point's `label`, else its `id`, else its 1-based position.
/// - `.fcsv`: Slicer's fiducial CSV. `# CoordinateSystem = LPS|RAS` (or the older 0 = RAS,
///   1 = LPS; RAS when absent, as Slicer ≤ 4.10 wrote), `# columns = ...` names the columns
///   (default `id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID`). Ids: the label,
///   else the id column. Fields may be double-quoted.
///
/// Ids must be unique in a file (a repeated one is an error naming the file and the point).

#include "imaging/io/csv.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// Which point set of a two-volume MNI tag file to read.
enum class TagVolume {
  FIRST,   ///< the first three coordinates (RESECT: MRI, pre-operative)
  SECOND,  ///< the last three (RESECT: ultrasound, intra-operative); a one-volume file's only set
};

/// Reads a landmark file of any format above, by its name's ending.
/// @param[in] path    the file.
/// @param[in] volume  the set of a two-volume tag file (ignored by the other formats and by a
///                    one-volume tag file).
/// @return ids and world RAS positions (mm), in file order.
/// \throws brainshift::Error, one line naming the file and, where it helps, the line or point:
/// missing or unreadable file, an unknown ending, a malformed header or point, a non-finite
/// coordinate, an unknown coordinate system, a repeated id, no points at all.
Landmarks read_landmark_file(const std::filesystem::path& path,
                             TagVolume volume = TagVolume::FIRST);

/// True when read_landmark_file() knows the file's ending.
bool is_landmark_file(const std::filesystem::path& path);

/// Writes landmarks as a Slicer markups file (one "Fiducial" markup, coordinateSystem "LPS",
/// positions converted from RAS), atomically. `descriptions` (empty, or one per landmark) become
/// the control points' descriptions, shown in Slicer's Markups module.
/// \throws brainshift::Error naming the path when it cannot be written or the sizes differ.
void write_markups_json(const std::filesystem::path& path, const Landmarks& landmarks,
                        const std::vector<std::string>& descriptions = {});

}  // namespace brainshift::imaging
