#pragma once
/// \file ingest.hpp
/// The ingest pipeline: read -> denoise -> bias correction -> resample -> threshold ->
/// clean-up -> column fit and mask -> optional labels, with a provenance record.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/filters.hpp"
#include "voxpack/ingest/image_io.hpp"

namespace voxpack::ingest {

/// Which phase is the void (pore) phase in the image.
enum class VoidPolarity { Auto, Bright, Dark };
/// Denoising before thresholding.
enum class DenoiseMethod { None, Median, MedianBox, Curvature };
/// How the threshold is chosen.
enum class ThresholdMethod { Otsu, KMeans, Manual };
/// How the column (mask) is obtained.
enum class ColumnMode { Auto, None, Explicit };

/// Every ingest option; defaults are the default pipeline.
struct IngestOptions {
  ReadOptions read;                                ///< reader options (--voxel-size)
  VoidPolarity voidPolarity = VoidPolarity::Auto;  ///< auto: the file's voxpack_void key, else dark
  DenoiseMethod denoise = DenoiseMethod::Median;   ///< Median: 7-point (face) median
  int medianRadiusVoxels = 1;                      ///< MedianBox half-width, 1..5
  CurvatureDiffusionOptions curvature;             ///< for DenoiseMethod::Curvature
  bool n4 = false;                                 ///< N4 bias correction (MRI)
  N4Options n4Options;                             ///< for n4
  double resampleMm = 0.0;                         ///< > 0: resample onto this isotropic voxel
  ThresholdMethod threshold = ThresholdMethod::Otsu;  ///< threshold choice
  double thresholdValue = 0.0;                        ///< for Manual, in image intensity units
  std::size_t maxSpeckVoxels = 8;        ///< solid components this small become void (0 = keep)
  std::size_t maxHoleVoxels = 8;         ///< void components this small become solid (0 = keep)
  ColumnMode column = ColumnMode::Auto;  ///< column detection
  double columnXMm = 0.0, columnYMm = 0.0, columnRadiusMm = 0.0;  ///< for Explicit, mm
  ColumnFitOptions columnFit;                                     ///< for Auto
  bool labels = false;                  ///< distance-map watershed particle labels
  double labelMarkerDepthVoxels = 1.0;  ///< watershed marker depth, voxels, >= 0
};

/// A segmented bed and the record of how it was made.
struct IngestResult {
  Bed bed;                   ///< indicator, optional mask and labels, provenance
  double thresholdUsed = 0;  ///< in image intensity units (after denoise/bias correction)
  bool voidBright = false;   ///< polarity used
  ColumnFit column;          ///< the column used (found = false: no mask)
  nlohmann::json report;     ///< same as bed.provenance["ingest"]
};

/// Runs the pipeline on `input`. Throws IoError/FormatError/InputError on bad input.
IngestResult ingestVolume(const std::filesystem::path& input, const IngestOptions& options,
                          int threads, Progress& progress = nullProgress());

/// Runs the pipeline after reading (for callers that already hold a volume).
IngestResult segmentVolume(Volume volume, const IngestOptions& options, int threads,
                           Progress& progress = nullProgress());

}  // namespace voxpack::ingest
