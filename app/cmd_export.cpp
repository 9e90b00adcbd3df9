// voxpack export IN.h5 --format F [-o OUT]: the bed out to CFD meshers (STL/OBJ surfaces
// with contact treatment), ParaView (XDMF sidecar, VTKHDF, VTK particle points), Fiji (TIFF
// slices), ITK tools (NRRD/MHA) and spreadsheets (CSV). docs/export.md describes each.
#include <filesystem>
#include <iostream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/export/formats.hpp"
#include "voxpack/export/surfaces.hpp"

namespace voxpack::app {
namespace {

namespace fs = std::filesystem;
using namespace voxpack::exporter;

class ExportCommand final : public Command {
 public:
  std::string name() const override { return "export"; }
  std::string description() const override {
    return "the bed for CFD, ParaView, Fiji, spreadsheets (stl obj xdmf vtkhdf vtk tiff nrrd mha "
           "csv)";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("file", input_, "bed file (.h5)")->required();
    sub.add_option("--format", format_,
                   "stl, obj (surfaces), xdmf (sidecar), vtkhdf, vtk (particle points), tiff "
                   "(folder of slices), nrrd, mha, csv (particle table)")
        ->required();
    sub.add_option("-o,--output", output_,
                   "output file (folder for tiff); default: beside the bed with the format's "
                   "extension");
    sub.add_option("--contacts", contacts_, "stl/obj: none, gap, overlap, bridge or cap")
        ->capture_default_str();
    sub.add_option("--contact-size", surf_.contactSize,
                   "in units of d: gap/overlap scale 1 -/+ S (default 0.01); bridge diameter and "
                   "cap flat diameter S*d (default 0.2)");
    sub.add_option("--contact-tolerance-mm", surf_.contactToleranceMm,
                   "surfaces closer than this count as touching (default: one voxel)");
    sub.add_option("--tolerance-mm", surf_.toleranceMm,
                   "chord tolerance of the tessellation (default: d/500)");
    sub.add_option("--wall-contacts", wallContacts_,
                   "stl/obj: wall parts that take contacts: all, side (round wall only: open "
                   "column ends for CFD) or none")
        ->capture_default_str();
    sub.add_flag("--no-wall", noWall_, "stl/obj: leave out the container wall solid");
    sub.add_flag("--surface", surface_,
                 "stl/obj: smoothed iso-surface of the indicator (imaged beds) instead of the "
                 "exact particle surfaces");
    sub.add_option("--smoothing-voxels", iso_.smoothingVoxels,
                   "--surface: Gaussian sigma in voxels (0 = none)")
        ->capture_default_str();
    sub.add_option("--taubin-iterations", iso_.taubinIterations,
                   "--surface: Taubin smoothing passes")
        ->capture_default_str();
    sub.add_flag("--link", link_, "vtkhdf: external links into the bed file instead of copies");
    sub.add_flag("--json", json_, "print what was written as JSON on stdout");
  }

  int execute(const GlobalOptions& global) override {
    const Format format = parseFormat(format_);
    const fs::path out = output_.empty() ? defaultOutput(input_, format) : fs::path(output_);
    const int threads = resolveThreads(global.threads);
    CommandProgress progress(global);
    const LatticeDatasets header = readLatticeDatasets(input_);
    const std::uint64_t voxels =
        checkedProduct({header.dims[0], header.dims[1], header.dims[2]}, "bed dims");
    nlohmann::json report = {{"voxpack_version", versionString()},
                             {"input", input_},
                             {"format", format_},
                             {"output", out.string()}};
    if (format == Format::Xdmf) {
      report["datasets"] = writeXdmf(input_, out);
    } else if (format == Format::VtkHdf) {
      // Copies stream through HDF5 chunk by chunk: a few chunks in memory, not the bed.
      report["datasets"] = writeVtkHdf(input_, out, {link_});
      report["linked"] = link_;
    } else {
      std::uint64_t estimate = header.bytesOnLattice;  // the bed in memory
      if (format == Format::Nrrd || format == Format::Mha)
        estimate += 8 * voxels;                                 // float copy + ITK
      if (surface_) estimate += 4 * voxels + 64 * voxels / 10;  // field + mesh (~0.1 tri/voxel)
      requireWithinBudget(estimate, global.memory, "export of " + input_);
      const Bed bed = readBed(input_);
      switch (format) {
        case Format::Stl:
        case Format::Obj: {
          SurfaceResult r;
          if (surface_) {
            iso_.threads = threads;
            r = indicatorSurface(bed, iso_, progress);
          } else {
            surf_.contacts = parseContactTreatment(contacts_);
            surf_.wall = !noWall_;
            surf_.wallContacts = parseWallContacts(wallContacts_);
            surf_.threads = threads;
            r = particleSurfaces(bed, surf_, progress);
          }
          const int digits = r.report.value("text_digits", 9);
          if (format == Format::Stl)
            writeStl(r.solids, out, digits);
          else
            writeObj(r.solids, out, digits);
          report.update(r.report);
          break;
        }
        case Format::Vtk: {
          ParticleFields f;
          if (bed.labels)
            f.coordinationLabels = labelCoordination(*bed.labels, bed.particles.size(), threads);
          writeParticleVtk(bed.particles, f, out);
          report["particles"] = bed.particles.size();
          report["coordination_from_labels"] = bed.labels.has_value();
          break;
        }
        case Format::Tiff:
          writeTiffStack(bed.indicator, out, progress);
          report["slices"] = bed.lattice().nz();
          break;
        case Format::Nrrd:
        case Format::Mha: {
          const std::string ext = out.extension().string();
          if (format == Format::Nrrd && ext != ".nrrd" && ext != ".nhdr")
            throw UsageError("-o: a nrrd output needs the extension .nrrd or .nhdr");
          if (format == Format::Mha && ext != ".mha" && ext != ".mhd")
            throw UsageError("-o: an mha output needs the extension .mha or .mhd");
          writeIndicatorImage(bed.indicator, out);
          break;
        }
        case Format::Csv:
          writeParticleCsv(bed.particles, out);
          report["particles"] = bed.particles.size();
          break;
        default:
          break;
      }
    }
    std::error_code ec;
    if (fs::is_regular_file(out, ec)) report["bytes"] = fs::file_size(out, ec);
    if (json_) {
      sanitizeNonFinite(report);
      std::cout << report.dump(2) << '\n';
    } else if (!global.quiet) {
      std::cerr << "wrote " << out.string() << '\n';
    }
    return 0;
  }

 private:
  std::string input_, format_, output_;
  std::string contacts_ = "none", wallContacts_ = "all";
  SurfaceOptions surf_;
  IsoSurfaceOptions iso_;
  bool noWall_ = false, surface_ = false, link_ = false, json_ = false;
};

}  // namespace

std::unique_ptr<Command> makeExportCommand() { return std::make_unique<ExportCommand>(); }

}  // namespace voxpack::app
