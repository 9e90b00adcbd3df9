#pragma once
/// \file ingest.hpp
/// The ingest pipeline: read -> denoise -> bias correction -> resample -> preliminary
/// threshold -> column fit (sub-voxel, on the grey wall step) -> phase levels and the
/// mean-intensity void fraction -> volume-preserving threshold -> clean-up -> mask ->
/// optional labels and calibration, with a provenance record (docs/ingest.md).

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/ingest/column.hpp"
#include "voxpack/ingest/filters.hpp"
#include "voxpack/ingest/image_io.hpp"
#include "voxpack/ingest/phases.hpp"

namespace voxpack::ingest {

/// Which phase is the void (pore) phase in the image.
enum class VoidPolarity { Auto, Bright, Dark };
/// Denoising before thresholding.
enum class DenoiseMethod { None, Median, MedianBox, Curvature };
/// How the threshold is chosen. Auto: Volume when the histogram shows two clear phases,
/// else Otsu. Volume: the threshold that reproduces the mean-intensity void fraction.
enum class ThresholdMethod { Auto, Volume, Otsu, KMeans, Manual };
/// Noise model of the phase-level fit: Auto = Rician when the void is bright (MRI).
enum class NoiseChoice { Auto, Gaussian, Rician };
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
  int deconvolveIterations = 0;  ///< > 0: Richardson-Lucy steps before the threshold
  double psfSigmaMm = 0.0;       ///< deconvolution PSF sigma; 0 = the blur fitted at the wall
  N4Options n4Options;           ///< for n4
  double resampleMm = 0.0;       ///< > 0: resample onto this isotropic voxel
  ThresholdMethod threshold = ThresholdMethod::Auto;  ///< threshold choice
  NoiseChoice noise = NoiseChoice::Auto;              ///< noise model of the level fit
  double thresholdValue = 0.0;                        ///< for Manual, in image intensity units
  std::size_t maxSpeckVoxels = 8;        ///< solid components this small become void (0 = keep)
  std::size_t maxHoleVoxels = 8;         ///< void components this small become solid (0 = keep)
  ColumnMode column = ColumnMode::Auto;  ///< column detection
  double columnXMm = 0.0, columnYMm = 0.0, columnRadiusMm = 0.0;  ///< for Explicit, mm
  ColumnFitOptions columnFit;                                     ///< for Auto
  bool refineColumn = true;  ///< Auto: refine the fit on the grey wall step (sub-voxel)
  /// > 0: the column wall's thickness in mm, known (a prior for the refinement; needed when
  /// the wall is thinner than ~2.5 voxels); 0: fitted.
  double columnWallMm = 0.0;
  /// Volume threshold with a refined column: divide the wall's blur out of the grey values
  /// next to it (correctWallBlur) and aim the porosity over the whole column.
  bool wallBlurCorrection = true;
  /// Volume threshold: aim the porosity over the bed's slices only (bedSlices of the
  /// preliminary segmentation), not the headspace above it or a lid; false: every slice.
  bool volumeOverBedSlices = true;
  /// Volume threshold: each phase's level from the far tail of its deep voxels (a normal of
  /// the phase's noise fitted to it; gaps blur closed only ever lower it) instead of their
  /// mean. Wrong under an intensity inhomogeneity (bias field, cupping): off by default.
  bool phaseLevelTail = false;
  /// Volume threshold with the 7-point median: below this many voxels per particle diameter
  /// (measured on the preliminary segmentation) the threshold cuts the raw image instead
  /// (the median closes thin void throats). 0: always the median.
  double medianMinVoxelsPerD = 18.0;
  /// MRI edge correction: S_V is read again on the segmentation (and the larger one used)
  /// when noise displaces an interface crossing by at most this many voxels (sd:
  /// sqrt(2 pi) sqrt(blur^2 + 1/12) / SNR); beyond it noise roughens the segmentation's
  /// interfaces. 0: the preliminary segmentation's S_V only.
  double surfaceRereadMaxJitter = 0.3;
  bool labels = false;                  ///< distance-map watershed particle labels
  double labelMarkerDepthVoxels = 1.0;  ///< watershed marker depth, voxels, >= 0
  int calibrationRuns = 0;              ///< > 0: calibrate the density bias with this many phantoms
  std::uint64_t calibrationSeed = 1;    ///< first phantom seed of the calibration
};

/// Image quality read from the input (all NaN/0 when not measurable).
struct ImageQuality {
  double noiseSigma = 0;         ///< noise sigma in image units (bright peak's outer flank)
  double snr = 0;                ///< phase contrast (noise-free signals) / noise sigma
  double blurMm = 0;             ///< Gaussian sigma of the wall's edge-spread function, mm
  bool blurMeasured = false;     ///< false when no wall was seen (blurMm unknown)
  double voxelMm = 0;            ///< in-plane voxel size, mm
  double voxelsPerDiameter = 0;  ///< sphere-equivalent particle diameter 6V/S in voxels
};

/// The void polarity the pipeline uses: the option; under Auto the header key voxpack_void
/// ("bright" or "dark", as a phantom writes it); else dark, as in XMT. `source` (optional)
/// names which.
bool resolveVoidBright(VoidPolarity polarity, const std::map<std::string, std::string>& metadata,
                       std::string* source = nullptr);

/// Resident memory of `voxpack ingest` before any volume is read (code, ITK, HDF5 and the
/// other libraries, heap arenas): measured on a 2³ NRRD (docs/scale.md).
inline constexpr std::uint64_t kIngestProcessBaseBytes = std::uint64_t{44} << 20;

/// Peak memory of the pipeline on an input of `input` voxels, bytes (before reading),
/// kIngestProcessBaseBytes included. `voidBright`: the polarity when known from the header
/// (a dark void needs no Rician copy of the raw image), else the worst case; `threads`: the
/// pipeline's threads (each holds per-slice buffers).
std::uint64_t estimateIngestPeakBytes(const Lattice& input, const IngestOptions& options,
                                      std::optional<bool> voidBright = std::nullopt,
                                      int threads = 1);

/// A segmented bed and the record of how it was made.
struct IngestResult {
  Bed bed;                   ///< indicator, optional mask and labels, provenance
  double thresholdUsed = 0;  ///< in image intensity units (after denoise/bias correction)
  bool voidBright = false;   ///< polarity used
  ColumnFit column;          ///< the column used (found = false: no mask)
  ImageQuality quality;      ///< measured image quality
  nlohmann::json report;     ///< same as bed.provenance["ingest"]
};

/// Runs the pipeline on `input`. Throws IoError/FormatError/InputError on bad input.
IngestResult ingestVolume(const std::filesystem::path& input, const IngestOptions& options,
                          int threads, Progress& progress = nullProgress());

/// Runs the pipeline after reading (for callers that already hold a volume).
IngestResult segmentVolume(Volume volume, const IngestOptions& options, int threads,
                           Progress& progress = nullProgress());

/// Expected density bias of this segmentation: the ingested bed itself is imaged by
/// `makePhantom` at the measured SNR, blur and voxel size (its mask as the column, wall
/// of the measured thickness), segmented with the same options, and compared with itself
/// over its packed slices. Runs options.calibrationRuns phantoms; the result is the
/// provenance object "calibration". `trimPlanes` leaves that many planes out at each end of
/// the packed slices (a bed cut from a taller one, whose cut ends the phantom's blur reads
/// wrongly).
nlohmann::json calibrateDensityBias(const IngestResult& result, const IngestOptions& options,
                                    int threads, Progress& progress = nullProgress(),
                                    std::int64_t trimPlanes = 0);

/// Packing density of `bed` over its packed slices: slices whose solid share in the mask
/// is at least half the largest slice's (the headspace above a bed is left out), fully
/// solid slices (a floor or lid) excluded. NaN when the mask is empty.
double packedRegionDensity(const Bed& bed, std::int64_t* firstSlice = nullptr,
                           std::int64_t* lastSlice = nullptr);

/// The bed's slices {first, last}: the longest run of slices whose solid share inside
/// `mask` (null: the whole slice) is at least half the median share of the slices holding
/// any bed; {-1, -1} when there is none. Leaves out the headspace and a lid.
std::pair<std::int64_t, std::int64_t> bedSlices(const Grid<std::uint8_t>& indicator,
                                                const Grid<std::uint8_t>* mask);

/// bedSlices' rule on per-slice counts: `in` voxels of the region and `solid` of them solid
/// (the streamed path's shares come from the mean intensity, not a segmentation).
std::pair<std::int64_t, std::int64_t> bedSlicesFromCounts(const std::vector<double>& in,
                                                          const std::vector<double>& solid);

/// Sphere-equivalent particle diameter 6V/S in voxels = 1.5 x the mean solid chord along
/// x, y, z inside `region` (null: everywhere); 0 when there is no solid chord.
double voxelsPerDiameter(const Grid<std::uint8_t>& indicator, const Grid<std::uint8_t>* region);

}  // namespace voxpack::ingest
