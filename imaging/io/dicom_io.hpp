#pragma once
/// @file
/// @brief DICOM image series (GDCM) read into and written from world RAS volumes (mm).
///
/// DICOM's patient frame is LPS: Image Position (Patient) is the centre of a slice's first
/// pixel, Image Orientation (Patient) the row and column directions, Pixel Spacing "between
/// rows \ between columns". Here a series becomes a volume whose i axis runs along a row, j down
/// the columns and k along row × column, ordered by position (not by file name or Instance
/// Number); origin and directions are converted to RAS by negating x and y.
///
/// Reading: classic single-frame images (any storage class GDCM decodes: CT, MR, secondary
/// capture; compressed transfer syntaxes included), one sample per pixel, Rescale Slope and
/// Intercept applied. Refused with a one-line error naming the path: no DICOM file, several
/// series in one folder (pass a file of the one wanted), multi-frame images, mixed orientations or
/// sizes, slices not along the normal (gantry tilt), duplicate or unevenly spaced slices.
///
/// Writing: a new MR Image Storage series derived from `source` (patient, study and frame of
/// reference kept when they are known; new series and instance UIDs), one file per slice,
/// explicit VR little endian, signed 16-bit with Rescale Slope / Intercept chosen so that the
/// float values round-trip to within half a slope (integer-valued volumes in range: exact).

#include "imaging/io/volume.hpp"

#include <filesystem>
#include <string>

namespace brainshift::imaging {

/// What a derived series keeps from its source: patient, study, frame of reference. Empty
/// strings are unknown (type-2 elements are then written empty, UIDs generated).
struct DicomSeriesInfo {
  std::string patient_name, patient_id, patient_birth_date, patient_sex;
  std::string study_instance_uid, study_date, study_time, study_id, accession_number,
      study_description;
  std::string frame_of_reference_uid;
  std::string series_instance_uid, series_description, modality;
  int series_number = 0;
};

/// True when `path` is read as DICOM: a folder, a file named .dcm or .ima (any case), or a
/// file with the "DICM" marker at byte 128.
bool is_dicom_path(const std::filesystem::path& path);

/// Reads the series in folder `path`, or the series of the DICOM file `path` from its folder,
/// into world RAS (mm). @param[out] info  when not null: the source's identity (see above).
/// \throws brainshift::Error, one line naming the path (see the file comment).
VolumeF read_dicom_series(const std::filesystem::path& path, DicomSeriesInfo* info = nullptr);

/// Writes `volume` (one component, world RAS) as an MR series into the existing folder `dir`,
/// files IMG0001.dcm … in slice order. `source` gives the patient, study and frame of reference
/// kept; `description` is the Series Description (≤ 64 characters).
/// \throws brainshift::Error naming `dir`: not one component, non-finite values, a description
/// too long, or a failed write.
void write_dicom_series(const std::filesystem::path& dir, const VolumeF& volume,
                        const DicomSeriesInfo& source, const std::string& description);

/// The series description brainshift gives a corrected image: it says what it is and that it is
/// not for diagnosis.
inline constexpr const char* corrected_series_description =
    "Brain-shift corrected (brainshift) - NOT FOR DIAGNOSIS";

}  // namespace brainshift::imaging
