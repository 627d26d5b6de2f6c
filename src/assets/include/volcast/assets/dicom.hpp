#pragma once
// CT series for the virtual monitor: DICOM slices in Hounsfield units and an optional DICOM SEG
// overlay (window/level: volcast/room/patient_case.hpp, where the monitor is drawn from).
//
// Sources: DICOM PS3.3 C.7.6.2 (Image Plane: ImagePositionPatient, ImageOrientationPatient,
// PixelSpacing), C.11.1.1.2 (Modality LUT: HU = stored value * RescaleSlope + RescaleIntercept),
// A.51 (Segmentation IOD). Read with
// DCMTK (dcmdata, dcmseg).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace volcast {

/// A CT series as slices of width x height pixels, sorted along the slice normal (the cross
/// product of ImageOrientationPatient's row and column directions), in Hounsfield units.
struct DicomSeries {
  int width = 0, height = 0, slices = 0;
  /// Pixel spacing (column step, row step) and the distance between slice positions, mm.
  Eigen::Vector3d spacing_mm = Eigen::Vector3d::Ones();
  std::vector<Eigen::Vector3d>
      positions_mm;         ///< ImagePositionPatient of each slice (patient frame)
  std::vector<int16_t> hu;  ///< slices x height x width, row-major per slice
  std::string description;  ///< SeriesDescription (may be empty)
  /// The SEG overlay: same layout as `hu`, 1 where the segment is; empty without one.
  std::vector<uint8_t> overlay;
  std::string overlay_label;  ///< the segment's label ("Liver")
  int16_t at(int slice, int row, int column) const {
    return hu[(static_cast<size_t>(slice) * height + row) * width + column];
  }
};

/// Whether `file` is a DICOM Part 10 file (a 128-byte preamble, then "DICM").
bool is_dicom_file(const std::filesystem::path& file);

/// Reads every DICOM Part 10 image file in `folder` (not its subfolders) that is not a
/// Segmentation, as one series: all must have the same size, orientation and SeriesInstanceUID.
/// At most 2048 slices of at most 4096 x 4096 pixels. Throws Error naming the folder or file: none
/// found, a file that does not parse, compressed pixel data DCMTK cannot decode, mixed series or
/// sizes.
DicomSeries read_dicom_series(const std::filesystem::path& folder);

/// Adds a DICOM SEG's first segment (or the one labelled `label` if not empty) to `series` as its
/// overlay: each SEG frame goes to the slice at its PlanePositionSequence position (within half a
/// slice spacing). Throws Error if the file is not a binary/fractional SEG of the series' size,
/// or no frame matches a slice.
void read_dicom_seg(const std::filesystem::path& file, DicomSeries& series,
                    const std::string& label = "");

}  // namespace volcast
