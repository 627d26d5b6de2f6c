#include "volcast/assets/dicom.hpp"

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmfg/fgplanpo.h>
#include <dcmtk/dcmseg/segdoc.h>
#include <dcmtk/dcmseg/segment.h>
#include <dcmtk/dcmseg/segutils.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <optional>
#include <string_view>

#include "volcast/core/error.hpp"

namespace volcast {

namespace {

constexpr int kMaxSlices = 2048;
constexpr int kMaxSide = 4096;

struct Slice {
  std::filesystem::path file;
  Eigen::Vector3d position, row_dir, col_dir;
  std::vector<int16_t> hu;
  int width = 0, height = 0;
  double spacing_row = 1, spacing_col = 1;
  std::string series_uid, description;
};

std::string str(DcmDataset* d, const DcmTagKey& tag) {
  OFString s;
  return d->findAndGetOFStringArray(tag, s).good() ? std::string(s.c_str()) : std::string();
}

bool floats(DcmDataset* d, const DcmTagKey& tag, double* out, int n) {
  for (int i = 0; i < n; ++i)
    if (d->findAndGetFloat64(tag, out[i], i).bad()) return false;
  return true;
}

}  // namespace

bool is_dicom_file(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  char head[132] = {};
  return in.read(head, sizeof head) && std::string_view(head + 128, 4) == "DICM";
}

namespace {

// One image file, or nothing if it is a DICOM file that is not an image we show (a SEG, no pixels).
std::optional<Slice> read_slice(const std::filesystem::path& file) {
  if (!is_dicom_file(file)) return std::nullopt;
  DcmFileFormat format;
  if (format.loadFile(file.string().c_str()).bad()) return std::nullopt;  // not DICOM
  DcmDataset* d = format.getDataset();
  const std::string sop = str(d, DCM_SOPClassUID);
  if (sop == UID_SegmentationStorage || !d->tagExists(DCM_PixelData)) return std::nullopt;
  const std::string where = "DICOM " + file.string() + ": ";
  Slice s;
  s.file = file;
  Uint16 rows = 0, cols = 0, bits = 0, repr = 0, samples = 1;
  d->findAndGetUint16(DCM_Rows, rows);
  d->findAndGetUint16(DCM_Columns, cols);
  d->findAndGetUint16(DCM_BitsAllocated, bits);
  d->findAndGetUint16(DCM_PixelRepresentation, repr);
  d->findAndGetUint16(DCM_SamplesPerPixel, samples);
  if (rows < 1 || cols < 1 || rows > kMaxSide || cols > kMaxSide)
    throw Error(where + "image size " + std::to_string(cols) + "x" + std::to_string(rows) +
                " out of range");
  if (bits != 16 || samples != 1)
    throw Error(where + "only 16-bit grayscale images are shown (bits allocated " +
                std::to_string(bits) + ", samples " + std::to_string(samples) + ")");
  double ipp[3], iop[6], ps[2] = {1, 1};
  if (!floats(d, DCM_ImagePositionPatient, ipp, 3) ||
      !floats(d, DCM_ImageOrientationPatient, iop, 6))
    throw Error(where + "no ImagePositionPatient/ImageOrientationPatient");
  floats(d, DCM_PixelSpacing, ps, 2);
  double slope = 1, intercept = 0;
  d->findAndGetFloat64(DCM_RescaleSlope, slope);
  d->findAndGetFloat64(DCM_RescaleIntercept, intercept);
  if (d->chooseRepresentation(EXS_LittleEndianExplicit, nullptr).bad())
    throw Error(where + "its pixel data is compressed in a way this build cannot decode");
  const Uint16* pixels = nullptr;
  unsigned long count = 0;
  if (d->findAndGetUint16Array(DCM_PixelData, pixels, &count).bad() || !pixels ||
      count < static_cast<unsigned long>(rows) * cols)
    throw Error(where + "pixel data shorter than " + std::to_string(cols) + "x" +
                std::to_string(rows));
  s.width = cols, s.height = rows;
  s.position = {ipp[0], ipp[1], ipp[2]};
  s.row_dir = {iop[0], iop[1], iop[2]};
  s.col_dir = {iop[3], iop[4], iop[5]};
  s.spacing_row = ps[0], s.spacing_col = ps[1];
  s.series_uid = str(d, DCM_SeriesInstanceUID);
  s.description = str(d, DCM_SeriesDescription);
  s.hu.resize(static_cast<size_t>(rows) * cols);
  for (size_t i = 0; i < s.hu.size(); ++i) {
    const double stored = repr ? static_cast<double>(static_cast<int16_t>(pixels[i])) : pixels[i];
    s.hu[i] =
        static_cast<int16_t>(std::clamp(std::lround(stored * slope + intercept), -32768L, 32767L));
  }
  return s;
}

}  // namespace

DicomSeries read_dicom_series(const std::filesystem::path& folder) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec))
    throw Error("DICOM series " + folder.string() + ": not a folder");
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  std::vector<Slice> slices;
  for (const auto& f : files) {
    if (auto s = read_slice(f)) slices.push_back(std::move(*s));
    if (slices.size() > kMaxSlices)
      throw Error("DICOM series " + folder.string() + ": more than " + std::to_string(kMaxSlices) +
                  " slices");
  }
  if (slices.empty()) throw Error("DICOM series " + folder.string() + ": no DICOM images in it");
  const Slice& first = slices.front();
  const Eigen::Vector3d normal = first.row_dir.cross(first.col_dir);
  for (const Slice& s : slices)
    if (s.width != first.width || s.height != first.height || s.series_uid != first.series_uid ||
        (s.row_dir - first.row_dir).norm() > 1e-3 || (s.col_dir - first.col_dir).norm() > 1e-3)
      throw Error("DICOM series " + folder.string() + ": " + s.file.filename().string() +
                  " is of another series, size or orientation than " +
                  first.file.filename().string());
  std::sort(slices.begin(), slices.end(), [&](const Slice& a, const Slice& b) {
    return a.position.dot(normal) < b.position.dot(normal);
  });
  DicomSeries out;
  out.width = first.width, out.height = first.height;
  out.slices = static_cast<int>(slices.size());
  out.description = first.description;
  double step = 1;
  if (slices.size() > 1)
    step = (slices.back().position - slices.front().position).dot(normal) /
           static_cast<double>(slices.size() - 1);
  // PixelSpacing is (row spacing, column spacing): the step between rows, then between columns.
  out.spacing_mm = {first.spacing_col, first.spacing_row, std::abs(step)};
  out.hu.reserve(static_cast<size_t>(out.width) * out.height * out.slices);
  for (const Slice& s : slices) {
    out.positions_mm.push_back(s.position);
    out.hu.insert(out.hu.end(), s.hu.begin(), s.hu.end());
  }
  return out;
}

void read_dicom_seg(const std::filesystem::path& file, DicomSeries& series,
                    const std::string& label) {
  const std::string where = "DICOM SEG " + file.string() + ": ";
  DcmSegmentation* raw = nullptr;
  if (DcmSegmentation::loadFile(file.string().c_str(), raw).bad() || !raw)
    throw Error(where + "not a DICOM Segmentation this build can read");
  std::unique_ptr<DcmSegmentation> seg(raw);
  size_t segment_number = 0;
  for (size_t n = 1; n <= seg->getNumberOfSegments(); ++n) {
    DcmSegment* s = seg->getSegment(n);
    OFString name;
    if (s) s->getSegmentLabel(name);
    if (label.empty() || label == name.c_str()) {
      segment_number = n;
      series.overlay_label = name.c_str();
      break;
    }
  }
  if (!segment_number)
    throw Error(where + (label.empty() ? "no segments" : "no segment labelled '" + label + "'"));
  Uint16 rows = 0, cols = 0;
  {
    DcmFileFormat format;  // the frame size (DcmSegmentation keeps its pixel module protected)
    if (format.loadFile(file.string().c_str()).good()) {
      format.getDataset()->findAndGetUint16(DCM_Rows, rows);
      format.getDataset()->findAndGetUint16(DCM_Columns, cols);
    }
  }
  if (rows != series.height || cols != series.width)
    throw Error(where + std::to_string(cols) + "x" + std::to_string(rows) +
                " frames, the series is " + std::to_string(series.width) + "x" +
                std::to_string(series.height));
  OFVector<size_t> frames;
  seg->getFramesForSegment(segment_number, frames);
  const size_t pixels = static_cast<size_t>(rows) * cols;
  std::vector<uint8_t> overlay(pixels * series.slices, 0);
  const Eigen::Vector3d normal =
      series.slices > 1
          ? Eigen::Vector3d((series.positions_mm.back() - series.positions_mm.front()).normalized())
          : Eigen::Vector3d::UnitZ();
  int matched = 0;
  for (size_t f : frames) {
    const DcmIODTypes::Frame* frame = seg->getFrame(f);
    auto* plane = dynamic_cast<FGPlanePosPatient*>(
        seg->getFunctionalGroups().get(static_cast<Uint32>(f), DcmFGTypes::EFG_PLANEPOSPATIENT));
    if (!frame || !plane) continue;
    Eigen::Vector3d p;
    if (plane->getImagePositionPatient(p.x(), p.y(), p.z()).bad()) continue;
    int slice = -1;
    for (int s = 0; s < series.slices; ++s)
      if (std::abs((series.positions_mm[s] - p).dot(normal)) < 0.5 * series.spacing_mm.z() + 1e-3)
        slice = s;
    if (slice < 0) continue;
    std::unique_ptr<DcmIODTypes::Frame> unpacked;
    const uint8_t* bits = frame->pixData;
    if (frame->length < pixels) {  // binary SEG frames as stored: 8 pixels per byte
      unpacked.reset(DcmSegUtils::unpackBinaryFrame(frame, rows, cols));
      if (!unpacked || unpacked->length < pixels)
        throw Error(where + "frame " + std::to_string(f) + " is short");
      bits = unpacked->pixData;
    }
    uint8_t* dst = overlay.data() + pixels * slice;
    for (size_t i = 0; i < pixels; ++i) dst[i] = dst[i] | (bits[i] ? 1 : 0);
    ++matched;
  }
  if (!matched) throw Error(where + "none of its frames lies on a slice of the series");
  series.overlay = std::move(overlay);
}

}  // namespace volcast
