#pragma once
// Private bridge between the ITK translation units (itk_io.cpp, itk_filters.cpp) and the
// rest of the module. ITK 5.2 ships its own older Eigen whose headers share include
// guards with the system Eigen 3.4 that core's Lattice uses: the two cannot meet in one
// translation unit. So the ITK side sees only this plain header (no Eigen, no Grid).
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace voxpack::ingest::bridge {

/// A scalar volume as plain arrays; all triples in (z, y, x) order.
template <class T>
struct Raw {
  std::array<std::int64_t, 3> dims{0, 0, 0};  ///< (nz, ny, nx)
  std::array<double, 3> spacing{1, 1, 1};     ///< mm
  std::array<double, 3> origin{0, 0, 0};      ///< mm, centre of voxel [0,0,0]
  std::vector<T> data;                        ///< C order [z][y][x]
};

/// Header facts of one image file.
struct Header {
  std::string imageIO;                          ///< ITK ImageIO class name
  std::string componentType;                    ///< stored component type
  unsigned dimensions = 0;                      ///< number of dimensions in the file
  std::array<std::size_t, 4> size{1, 1, 1, 1};  ///< (x, y, z, t) sizes, 1 beyond dimensions
  std::array<double, 3> spacing{1, 1, 1};       ///< (x, y, z) spacing from the file
  std::array<double, 3> origin{0, 0, 0};        ///< (x, y, z) origin from the file
  std::map<std::string, std::string> metadata;  ///< string key/value pairs
};

/// Registers the IO factories once; returns the registered ImageIO class names.
std::vector<std::string> registerFactories();
/// Reads the header of `file`; throws FormatError when ITK has no reader or it fails.
Header readHeader(const std::string& file);
/// Reads a whole file as a 3-D float volume.
Raw<float> readFile(const std::string& file);
/// Reads a 2-D file (a slice) into `dst` (nx*ny floats).
void readSlice(const std::string& file, float* dst, std::size_t count);
/// True when GDCM recognises `file` as DICOM.
bool isDicom(const std::string& file);
/// Reads the first DICOM series of `dir`; `files` receives the slice files in order.
Raw<float> readDicomSeries(const std::string& dir, std::vector<std::string>& files,
                           std::string& componentType, std::size_t& seriesCount);
/// True when ITK has a writer for the file name's extension.
bool canWrite(const std::string& file);
/// Writes `image` with pixel type 0 = uint8, 1 = uint16, 2 = float32 (values already
/// clamped by the caller), with string metadata.
void write(const std::string& file, const Raw<float>& image, int pixelType,
           const std::map<std::string, std::string>& metadata);

/// Writes one DICOM file (int16, MR) per z slice into `dir`, one study and series.
void writeDicomSeries(const std::string& dir, const Raw<float>& image);

/// Curvature anisotropic diffusion in place (unit spacing).
void curvatureDiffusion(Raw<float>& image, int iterations, double conductance, double timeStep,
                        int threads);
/// Richardson-Lucy deconvolution in place with a normalised Gaussian kernel of
/// `sigmaVoxels` (z, y, x; voxels), `iterations` steps. The image must be >= 0.
void richardsonLucy(Raw<float>& image, const std::array<double, 3>& sigmaVoxels, int iterations,
                    int threads);
/// N4 on the voxels where mask != 0; divides `image` by the field; returns log-field range.
double n4(Raw<float>& image, const std::vector<std::uint8_t>& mask, int shrinkFactor, int levels,
          int iterationsPerLevel, double convergence, int controlPoints, int threads);
/// Watershed basins of the distance map of `solid` (1 = solid); raw ITK labels.
std::vector<std::uint32_t> watershed(const Raw<std::uint8_t>& solid, double level, int threads);

}  // namespace voxpack::ingest::bridge
