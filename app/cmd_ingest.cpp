// voxpack ingest INPUT -o OUT.h5: an imaged volume (MRI/XMT) to a segmented bed file.
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "command.hpp"
#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/communicator.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/ingest/ingest.hpp"
#include "voxpack/ingest/stream.hpp"

namespace voxpack::app {
namespace {

namespace fs = std::filesystem;
using namespace voxpack::ingest;

double parseNumber(const std::string& text, const std::string& option) {
  std::istringstream in(text);
  double v = 0;
  char extra = 0;
  if (!(in >> v) || (in >> extra) || !std::isfinite(v))
    throw UsageError(option + " '" + text + "': not a number");
  return v;
}

class IngestCommand final : public Command {
 public:
  std::string name() const override { return "ingest"; }
  std::string description() const override {
    return "segment an imaged volume (MRI/XMT) into a bed file";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("input", input_,
                   "3-D image file (NRRD, MHA/MHD, NIfTI, TIFF, VTK, ...), a folder of slices, "
                   "a DICOM series folder, or a Bruker 2dseq")
        ->required();
    sub.add_option("-o,--output", output_, "output bed file (.h5)")->required();
    sub.add_option("--void", void_,
                   "void (pore) phase: bright (MRI water), dark (XMT air), "
                   "auto (phantom header, else dark)")
        ->check(CLI::IsMember({"auto", "bright", "dark"}))
        ->capture_default_str();
    sub.add_option("--threshold", threshold_,
                   "auto (volume when two phases are clear, else otsu), volume (reproduces the "
                   "mean-intensity porosity), otsu, kmeans, or an intensity value")
        ->capture_default_str();
    sub.add_option("--noise", noise_,
                   "noise model of the phase-level fit: auto (rician when the void is bright), "
                   "gaussian, rician")
        ->check(CLI::IsMember({"auto", "gaussian", "rician"}))
        ->capture_default_str();
    sub.add_flag("!--no-refine-column", o_.refineColumn,
                 "keep the voxel-level circle fit (no sub-voxel fit on the grey wall step)");
    sub.add_option(
           "--column-wall-mm", o_.columnWallMm,
           "the column wall's thickness in mm when known (held in the sub-voxel wall "
           "fit; a wall thinner than ~2.5 voxels is otherwise fitted too thick and the "
           "radius too small; XMT-like walls with their own grey level only, not a signal-free "
           "MRI wall); 0 = fitted")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub.add_option("--calibrate", o_.calibrationRuns,
                   "error budget: re-image the ingested bed N times (1..50) at the measured SNR, "
                   "blur and voxel size and report the density bias (provenance \"calibration\")")
        ->capture_default_str();
    sub.add_option("--calibrate-seed", o_.calibrationSeed, "first phantom seed of --calibrate")
        ->capture_default_str();
    sub.add_option("--column", column_, "auto, none, or CX,CY,R in mm (vertical axis)")
        ->capture_default_str();
    sub.add_option("--deconvolve", o_.deconvolveIterations,
                   "Richardson-Lucy deconvolution with this many iterations before the "
                   "threshold (0 = off), Gaussian PSF of the blur fitted at the column wall "
                   "or --psf-sigma-mm")
        ->check(CLI::Range(0, 200));
    sub.add_option("--psf-sigma-mm", o_.psfSigmaMm,
                   "--deconvolve: the PSF's Gaussian sigma in mm (default: the wall's blur)")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--resample", o_.resampleMm, "resample onto this isotropic voxel (mm)")
        ->check(CLI::PositiveNumber);
    sub.add_option("--voxel-size", o_.read.voxelSizeMm,
                   "isotropic voxel size in mm (overrides the file's spacing)")
        ->check(CLI::PositiveNumber);
    sub.add_option("--denoise", denoise_,
                   "median (voxel + 6 face neighbours), median-box (--median-radius), "
                   "curvature (anisotropic diffusion) or none")
        ->check(CLI::IsMember({"none", "median", "median-box", "curvature"}))
        ->capture_default_str();
    sub.add_option("--median-min-voxels-per-d", o_.medianMinVoxelsPerD,
                   "median: below this many voxels per particle diameter (measured on a "
                   "preliminary segmentation) the volume threshold cuts the raw image, because "
                   "the median closes thin void throats (0 = always the median)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub.add_option("--surface-reread-max-jitter", o_.surfaceRereadMaxJitter,
                   "MRI edge correction: read the interface density again on the segmentation "
                   "when noise moves an interface by at most this many voxels (sd), else keep "
                   "the preliminary one (0 = never)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub.add_flag("!--no-wall-blur-correction", o_.wallBlurCorrection,
                 "volume threshold: keep the grey values next to the column wall as imaged "
                 "(default: divide the wall's fitted blur profile out of them)");
    sub.add_option("--volume-region", volumeRegion_,
                   "volume threshold: aim the mean-intensity porosity over the bed's slices "
                   "(bed: the headspace above it and a lid left out) or over every slice of the "
                   "column (column)")
        ->check(CLI::IsMember({"bed", "column"}))
        ->capture_default_str();
    sub.add_option("--phase-level", phaseLevel_,
                   "volume threshold: each phase's level from the voxels deep inside it, their "
                   "mean (mean) or a normal fitted to the tail away from the other phase (tail: "
                   "immune to gaps the blur closed, wrong under a bias field)")
        ->check(CLI::IsMember({"mean", "tail"}))
        ->capture_default_str();
    sub.add_option("--median-radius", o_.medianRadiusVoxels,
                   "median-box half-width in voxels (1..5)")
        ->check(CLI::Range(1, 5))
        ->capture_default_str();
    sub.add_option("--diffusion-iterations", o_.curvature.iterations,
                   "curvature diffusion steps (1..100)")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    sub.add_option("--diffusion-conductance", o_.curvature.conductance,
                   "curvature diffusion conductance (> 0)")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    sub.add_option("--bias-correction", bias_, "none or n4 (N4 bias-field correction, MRI)")
        ->check(CLI::IsMember({"none", "n4"}))
        ->capture_default_str();
    sub.add_option("--n4-shrink", o_.n4Options.shrinkFactor, "N4 shrink factor (1..16)")
        ->check(CLI::Range(1, 16))
        ->capture_default_str();
    sub.add_option("--max-speck-voxels", o_.maxSpeckVoxels,
                   "solid specks of at most this many voxels become void (0 = keep)")
        ->capture_default_str();
    sub.add_option("--max-hole-voxels", o_.maxHoleVoxels,
                   "holes (void) of at most this many voxels inside solid are filled (0 = keep)")
        ->capture_default_str();
    sub.add_flag("--labels", o_.labels, "write /labels: distance map + watershed particle labels");
    sub.add_option("--marker-depth", o_.labelMarkerDepthVoxels,
                   "watershed marker depth in voxels (>= 0)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub.add_flag("--json", json_, "print the ingest report as JSON on stdout");
    sub.add_option("--slab-voxels", slabPlanes_,
                   "stream in z-slabs this many voxels (planes) thick, whatever the memory "
                   "(default: stream only past --memory-limit; see docs/scale.md)")
        ->check(CLI::PositiveNumber);
  }

  int execute(const GlobalOptions& global) override {
    const Communicator& comm = Communicator::world();
    return runOnRanks(comm, [&] { return run(global, comm); });
  }

 private:
  int run(const GlobalOptions& global, const Communicator& comm) {
    o_.voidPolarity = void_ == "bright" ? VoidPolarity::Bright
                      : void_ == "dark" ? VoidPolarity::Dark
                                        : VoidPolarity::Auto;
    o_.denoise = denoise_ == "median"       ? DenoiseMethod::Median
                 : denoise_ == "median-box" ? DenoiseMethod::MedianBox
                 : denoise_ == "curvature"  ? DenoiseMethod::Curvature
                                            : DenoiseMethod::None;
    o_.n4 = bias_ == "n4";
    o_.volumeOverBedSlices = volumeRegion_ == "bed";
    o_.phaseLevelTail = phaseLevel_ == "tail";
    o_.noise = noise_ == "rician"     ? NoiseChoice::Rician
               : noise_ == "gaussian" ? NoiseChoice::Gaussian
                                      : NoiseChoice::Auto;
    if (o_.calibrationRuns < 0 || o_.calibrationRuns > 50)
      throw UsageError("--calibrate " + std::to_string(o_.calibrationRuns) +
                       ": the number of runs must be 1..50");
    if (threshold_ == "auto") {
      o_.threshold = ThresholdMethod::Auto;
    } else if (threshold_ == "volume") {
      o_.threshold = ThresholdMethod::Volume;
    } else if (threshold_ == "otsu") {
      o_.threshold = ThresholdMethod::Otsu;
    } else if (threshold_ == "kmeans") {
      o_.threshold = ThresholdMethod::KMeans;
    } else {
      o_.threshold = ThresholdMethod::Manual;
      o_.thresholdValue = parseNumber(threshold_, "--threshold");
    }
    if (column_ == "auto") {
      o_.column = ColumnMode::Auto;
    } else if (column_ == "none") {
      o_.column = ColumnMode::None;
    } else {
      std::vector<double> v;
      std::stringstream ss(column_);
      for (std::string part; std::getline(ss, part, ',');)
        v.push_back(parseNumber(part, "--column"));
      if (v.size() != 3 || !(v[2] > 0.0))
        throw UsageError("--column '" + column_ + "': expected auto, none or CX,CY,R (mm, R > 0)");
      o_.column = ColumnMode::Explicit;
      o_.columnXMm = v[0];
      o_.columnYMm = v[1];
      o_.columnRadiusMm = v[2];
    }
    const fs::path out = output_;
    ensureWritableDirectory(out.has_parent_path() ? out.parent_path() : fs::path("."), false);
    // Refuse before the voxels are read when the pipeline would not fit in the budget.
    o_.read.beforeAllocate = [this, &global](const Lattice& l) {
      const std::string what = "ingest of " + input_ + " (" + std::to_string(l.dims[0]) + " x " +
                               std::to_string(l.dims[1]) + " x " + std::to_string(l.dims[2]) +
                               " voxels)";
      checkedProduct({static_cast<std::uint64_t>(l.dims[0]), static_cast<std::uint64_t>(l.dims[1]),
                      static_cast<std::uint64_t>(l.dims[2]), 64},
                     what);
      estimate_ = estimateIngestPeakBytes(l, o_, voidBright_, resolveThreads(global.threads));
      requireWithinBudget(estimate_, global.memory, what);
    };
    CommandProgress bar(global);
    // Every stage start is a poll: the in-memory pipeline polls nowhere else.
    StopAtStageProgress progress(bar);
    // The header alone decides: in memory when the pipeline fits the budget, else by
    // z-slab, else refused before any voxel is read.
    std::optional<VolumeHeader> header;
    try {
      header = readVolumeHeader(input_, o_.read);
    } catch (const Error&) {
      // Not read here: the in-memory reader below reports the problem as it always has.
    }
    // The polarity the pipeline will use, when the options or the header tell it.
    if (o_.voidPolarity != VoidPolarity::Auto || header)
      voidBright_ = resolveVoidBright(
          o_.voidPolarity, header ? header->info.metadata : std::map<std::string, std::string>{});
    if (comm.size() > 1) {
      // Under mpirun the ranks share the streamed path's slabs; the in-memory pipeline
      // would run whole on every rank.
      if (!header) header = readVolumeHeader(input_, o_.read);
      NullProgress quiet;
      int rc = 0;
      maybeStream(*header, global, comm.rank() == 0 ? static_cast<Progress&>(progress) : quiet, rc,
                  comm);
      return rc;
    }
    if (header)
      if (int rc = 0; maybeStream(*header, global, progress, rc, comm)) return rc;
    IngestResult r = ingestVolume(input_, o_, resolveThreads(global.threads), progress);
    r.bed.provenance["command_line"] = global.commandLine;
    r.report["memory_estimate_bytes"] = {
        {"in_memory", estimate_}, {"limit", global.memory.limitBytes}, {"path", "in_memory"}};
    progress.poll("ingest: before writing " + output_);
    writeBed(out, r.bed);
    if (json_) {
      std::cout << r.report.dump(2) << '\n';
      return 0;
    }
    if (!global.quiet) {
      const Lattice& l = r.bed.lattice();
      std::cout << "wrote " << output_ << ": " << l.dims[0] << " x " << l.dims[1] << " x "
                << l.dims[2] << " voxels of " << std::setprecision(4) << l.spacingMm[2]
                << " mm, threshold " << r.thresholdUsed << " ("
                << (r.voidBright ? "void bright" : "void dark") << "), porosity "
                << r.report["porosity"].dump();
      if (r.column.found)
        std::cout << ", column radius " << r.column.radiusMm << " +- " << r.column.radiusStdMm
                  << " mm at (" << r.column.axisXMm << ", " << r.column.axisYMm << ")";
      else
        std::cout << ", no column mask";
      std::cout << '\n';
      if (r.report.contains("calibration")) {
        const auto& c = r.report["calibration"];
        std::cout << "calibration: expected density bias " << c["density_bias"].dump() << " +- "
                  << c["density_bias_std"].dump() << " (" << c["n"].dump() << " phantoms)\n";
      }
    }
    return 0;
  }

 private:
  // Runs the streamed path when the in-memory one does not fit (or --slab-voxels asks);
  // false: run in memory. Throws ResourceError when neither fits.
  bool maybeStream(const VolumeHeader& h, const GlobalOptions& global, Progress& progress, int& rc,
                   const Communicator& comm) {
    const bool ranks = comm.size() > 1;
    const Lattice& l = h.lattice;
    const std::string what = "ingest of " + input_ + " (" + std::to_string(l.dims[0]) + " x " +
                             std::to_string(l.dims[1]) + " x " + std::to_string(l.dims[2]) +
                             " voxels)";
    checkedProduct({static_cast<std::uint64_t>(l.dims[0]), static_cast<std::uint64_t>(l.dims[1]),
                    static_cast<std::uint64_t>(l.dims[2]), 64},
                   what);
    const std::uint64_t inMemory =
        estimateIngestPeakBytes(l, o_, voidBright_, resolveThreads(global.threads));
    const bool fits = global.memory.fits(inMemory);
    if (fits && slabPlanes_ == 0 && !ranks) return false;
    const std::string why = streamedIngestUnsupported(o_, h);
    if (!why.empty() && ranks)
      throw UsageError("ingest under mpirun runs the streamed path, which has none for " + why);
    if (!why.empty()) {
      if (slabPlanes_ > 0 && fits) throw UsageError("--slab-voxels: no streamed ingest for " + why);
      requireWithinBudget(inMemory, global.memory,
                          what + " in memory (no streamed path for " + why + ")");
    }
    const int threads = resolveThreads(global.threads);
    std::int64_t planes = streamedSlabPlanes(h, o_, global.memory, slabPlanes_, threads);
    // Under mpirun without --slab-voxels, at least two slabs per rank, so every rank works
    // (a volume that fits the budget would otherwise be one slab); the provenance records
    // the slab thickness, and one process with that --slab-voxels writes the same bed.
    if (ranks && slabPlanes_ == 0)
      planes = std::min(
          planes, std::max<std::int64_t>(1, (l.nz() + 2 * comm.size() - 1) / (2 * comm.size())));
    requireWithinBudget(
        estimateStreamedIngestBytes(h, o_, std::max<std::int64_t>(planes, 1), threads),
        global.memory,
        what + " streamed in slabs of " + std::to_string(std::max<std::int64_t>(planes, 1)) +
            " planes (+ " + std::to_string(streamedHaloPlanes(o_, l.nz())) +
            " halo planes each side)");
    if (!global.quiet && comm.rank() == 0)
      progress.message("streaming: in memory would need about " + formatBytes(inMemory) +
                       "; slabs of " + std::to_string(planes) + " planes, about " +
                       formatBytes(estimateStreamedIngestBytes(h, o_, planes, threads)) +
                       (ranks ? " per rank, over " + std::to_string(comm.size()) + " ranks" : ""));
    const StreamedIngestResult r =
        ingestVolumeStreamed(h, o_, output_, planes, resolveThreads(global.threads), progress,
                             {{"command_line", global.commandLine}}, &comm);
    rc = 0;
    if (comm.rank() != 0) return true;  // rank 0 wrote the bed and reports
    if (json_) {
      std::cout << r.report.dump(2) << '\n';
      return true;
    }
    if (!global.quiet) {
      std::cout << "wrote " << output_ << ": " << l.dims[0] << " x " << l.dims[1] << " x "
                << l.dims[2] << " voxels of " << std::setprecision(4) << l.spacingMm[2]
                << " mm, threshold " << r.thresholdUsed << " ("
                << (r.voidBright ? "void bright" : "void dark") << "), porosity "
                << r.report["porosity"].dump();
      if (r.column.found)
        std::cout << ", column radius " << r.column.radiusMm << " mm at (" << r.column.axisXMm
                  << ", " << r.column.axisYMm << ")";
      else
        std::cout << ", no column mask";
      std::cout << " (streamed)\n";
    }
    return true;
  }

  std::int64_t slabPlanes_ = 0;
  std::string input_, output_;
  std::string void_ = "auto", threshold_ = "auto", column_ = "auto", denoise_ = "median",
              bias_ = "none", noise_ = "auto", volumeRegion_ = "bed", phaseLevel_ = "mean";
  bool json_ = false;
  std::uint64_t estimate_ = 0;      // of the in-memory pipeline, set before the voxels are read
  std::optional<bool> voidBright_;  // known from the options or the header
  IngestOptions o_;
};

}  // namespace

std::unique_ptr<Command> makeIngestCommand() { return std::make_unique<IngestCommand>(); }

}  // namespace voxpack::app
