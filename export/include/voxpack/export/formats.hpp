#pragma once
/// \file formats.hpp
/// Volume and table exports of a bed: XDMF sidecar, VTKHDF image, TIFF slice folder,
/// NRRD/MetaImage (through ingest's ITK writer), particle CSV and VTK particle points.
/// Namespace `exporter` because `export` is a C++ keyword.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "voxpack/core/bed.hpp"
#include "voxpack/core/progress.hpp"

namespace voxpack::exporter {

/// The formats of `voxpack export`.
enum class Format { Stl, Obj, Xdmf, VtkHdf, Vtk, Tiff, Nrrd, Mha, Csv };

/// Parses "stl" | "obj" | "xdmf" | "vtkhdf" | "vtk" | "tiff" | "nrrd" | "mha" | "csv";
/// throws UsageError otherwise.
Format parseFormat(const std::string& name);

/// The default output path for `bedPath` in `format` (beside the bed, its extension).
std::filesystem::path defaultOutput(const std::filesystem::path& bedPath, Format format);

/// Dims (nz, ny, nx) of a bed file's /indicator and the 3-D datasets on its lattice, read
/// from the header only (for memory estimates before loading). Throws IoError/FormatError.
struct LatticeDatasets {
  std::array<std::uint64_t, 3> dims{};  ///< (nz, ny, nx)
  std::vector<std::string> fields;      ///< dataset paths on the lattice
  std::uint64_t bytesOnLattice = 0;     ///< sum of those datasets' uncompressed sizes
};

/// Reads the LatticeDatasets of `bedPath`.
LatticeDatasets readLatticeDatasets(const std::filesystem::path& bedPath);

/// Writes an XDMF 3 sidecar at `out` that points into `bedPath` (relative path when both
/// sit in one folder tree): every 3-D dataset on the bed's lattice (indicator, mask,
/// labels, and flow fields [nz,ny,nx] or [nz,ny,nx,3]) as cell data of a uniform grid with
/// the bed's spacing and origin. Returns the dataset paths referenced.
std::vector<std::string> writeXdmf(const std::filesystem::path& bedPath,
                                   const std::filesystem::path& out);

/// Options of writeVtkHdf.
struct VtkHdfOptions {
  bool link = false;  ///< true: external links into the bed file instead of copies
};

/// Writes VTK's HDF5 image layout (`/VTKHDF`, Type ImageData, version 1.0) with the same
/// datasets as writeXdmf as PointData on the voxel centres; copies (H5Ocopy, compression
/// kept) or external links.
/// Atomic. Returns the dataset paths written.
std::vector<std::string> writeVtkHdf(const std::filesystem::path& bedPath,
                                     const std::filesystem::path& out,
                                     const VtkHdfOptions& options = {});

/// Writes one 8-bit uncompressed TIFF per z slice into the folder `dir` (created; must not
/// hold slice files already), `slice_KKKK.tif`, value = 255 * indicator (void white), with
/// the ImageJ calibration (XResolution/YResolution = 1/spacing, unit=mm, spacing=sz) so Fiji
/// opens the folder as a calibrated stack. The folder appears complete or not at all.
void writeTiffStack(const Grid<std::uint8_t>& indicator, const std::filesystem::path& dir,
                    Progress& progress = nullProgress());

/// Writes the indicator (0 solid, 1 void) as uint8 NRRD or MetaImage (by extension) with
/// spacing and origin, through ingest's ITK writer.
void writeIndicatorImage(const Grid<std::uint8_t>& indicator, const std::filesystem::path& out);

/// Particle coordination numbers from the labels: particles a != b are neighbours when two
/// face-adjacent voxels carry labels a and b. Index n is particle n (label n+1).
std::vector<int> labelCoordination(const Grid<std::uint32_t>& labels, std::size_t particles,
                                   int threads = 1);

/// Writes the particle table as CSV: id,shape,x_mm,y_mm,z_mm,qw,qx,qy,qz,volume_mm3
/// (id = label, 1-based; shape quoted; volume exact from the shape spec, empty when the
/// shape cannot be built, e.g. a mesh file not found). Atomic.
void writeParticleCsv(const ParticleTable& particles, const std::filesystem::path& out);

/// Per-particle fields written to the VTK particle file besides the table.
struct ParticleFields {
  std::vector<int> coordinationLabels;  ///< from labelCoordination (empty: not written)
  std::vector<int> coordinationExact;   ///< from exact-distance contacts (empty: not written)
};

/// Writes the particles as legacy VTK PolyData points (ASCII): point = centre; point data
/// id (SCALARS), axis (VECTORS: body +z in world), and FIELD arrays shape (index into the
/// dataset string array shape_specs), orientation (w,x,y,z), volume_mm3, and the
/// coordination arrays given. Atomic.
void writeParticleVtk(const ParticleTable& particles, const ParticleFields& fields,
                      const std::filesystem::path& out);

}  // namespace voxpack::exporter
