#pragma once
/// \file image_io.hpp
/// Reading imaged volumes with ITK (any registered 3-D format, slice folders, DICOM series,
/// Bruker 2dseq) into a float grid, and writing grids in any ITK-writable format.
/// ITK stays behind this interface: no ITK header is included here.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "voxpack/core/grid.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::ingest {

/// Pixel type of a written image.
enum class PixelType { UInt8, UInt16, Float32 };

/// Parses "uint8" | "uint16" | "float32"; throws UsageError otherwise.
PixelType parsePixelType(const std::string& name);

/// Options of readVolume.
struct ReadOptions {
  double voxelSizeMm = 0.0;  ///< > 0: isotropic spacing in mm that overrides the file's; 0 = keep
  /// Called with the volume's lattice once the header is read, before the voxels are
  /// (DICOM series: after reading); throw to refuse (e.g. a memory budget check).
  std::function<void(const Lattice&)> beforeAllocate = {};
};

/// What was read and how.
struct VolumeInfo {
  std::string source;              ///< "file", "slice-series", "dicom-series" or "bruker-2dseq"
  std::string imageIO;             ///< ITK ImageIO class name, e.g. "NrrdImageIO"
  std::string componentType;       ///< stored pixel component type, e.g. "unsigned_short"
  std::vector<std::string> files;  ///< files read, in slice order (one entry for a 3-D file)
  bool spacingFromFile = true;     ///< false when spacing was overridden or guessed
  std::map<std::string, std::string> metadata;  ///< string key/value pairs of the header
};

/// A volume read from disk: intensities as float on the input lattice.
struct Volume {
  Grid<float> image;  ///< intensities, [z][y][x]
  VolumeInfo info;    ///< provenance of the read
};

/// Reads `input`: a 3-D image file, a folder of 2-D slices (numeric order), a DICOM series
/// folder, or a Bruker `2dseq` file / a folder holding one. Throws IoError (missing,
/// unreadable) or FormatError (not a 3-D image, inconsistent slices, corrupt data).
Volume readVolume(const std::filesystem::path& input, const ReadOptions& options,
                  Progress& progress = nullProgress());

/// Writes `image` to `path` in the format its extension names, atomically (every file of a
/// multi-file format appears only once complete). Integer types are rounded and clamped.
/// `metadata` goes into the header where the format keeps key/value pairs (NRRD, MetaImage).
void writeVolume(const std::filesystem::path& path, const Grid<float>& image, PixelType type,
                 const std::map<std::string, std::string>& metadata = {});

/// Writes one 2-D file per z slice, `dir/<prefix><k:04d>.<extension>` (e.g. extension "tif").
void writeSliceSeries(const std::filesystem::path& dir, const std::string& prefix,
                      const std::string& extension, const Grid<float>& image, PixelType type);

/// Writes a DICOM series (int16, one file per z slice, one study/series) into `dir`, for
/// tests and demonstrations of the DICOM reader.
void writeDicomSeries(const std::filesystem::path& dir, const Grid<float>& image);

/// Names of the ITK ImageIO classes registered for reading (e.g. "NrrdImageIO").
std::vector<std::string> registeredImageIOs();

/// Orders file names by the last run of digits in them (then by name), as slice stacks
/// are numbered ("slice9" before "slice10").
std::vector<std::filesystem::path> numericOrder(std::vector<std::filesystem::path> files);

}  // namespace voxpack::ingest
