// voxpack phantom IN.h5 -o OUT.nrrd: a synthetic MRI/XMT image of a known bed.
#include <filesystem>
#include <iostream>
#include <sstream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/memory.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/core/progress.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/ingest/image_io.hpp"
#include "voxpack/ingest/phantom.hpp"

namespace voxpack::app {
namespace {

namespace fs = std::filesystem;
using namespace voxpack::ingest;

class PhantomCommand final : public Command {
 public:
  std::string name() const override { return "phantom"; }
  std::string description() const override {
    return "simulate an MRI or XMT image of a bed (ground truth for ingest)";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("input", input_, "bed file (.h5)")->required();
    sub.add_option("-o,--output", output_,
                   "output image; format by extension (.nrrd, .mha, .nii.gz, .tif, ...)")
        ->required();
    sub.add_option("--modality", modality_,
                   "mri (water bright, Rician noise) or xmt (solid "
                   "bright, Gaussian noise)")
        ->check(CLI::IsMember({"mri", "xmt"}))
        ->required();
    sub.add_option("--snr", o_.snr, "phase contrast / noise sigma (> 0)")
        ->check(CLI::PositiveNumber)
        ->required();
    sub.add_option("--blur-mm", o_.blurMm, "Gaussian blur sigma in mm (>= 0)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub.add_option("--bias", o_.biasFraction, "bias field amplitude F: gain in [1-F, 1+F], 0..1")
        ->check(CLI::Range(0.0, 0.999))
        ->capture_default_str();
    sub.add_option("--voxel-size", o_.voxelSizeMm, "output voxel size in mm (default: the bed's)")
        ->check(CLI::PositiveNumber);
    sub.add_option("--wall-mm", o_.wallThicknessMm,
                   "container wall thickness drawn outside the mask, mm (default 4 voxels)")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--seed", o_.seed, "noise and bias seed")->required();
    sub.add_option("--pixel-type", pixel_, "float32, uint16 or uint8")
        ->check(CLI::IsMember({"float32", "uint16", "uint8"}))
        ->capture_default_str();
  }

  int execute(const GlobalOptions& global) override {
    o_.modality = modality_ == "mri" ? Modality::Mri : Modality::Xmt;
    const PixelType type = parsePixelType(pixel_);
    const fs::path out = output_;
    const Bed bed = readBed(input_);
    // Refuse unbounded settings before any work: the blur limit and the memory estimate.
    if (o_.blurMm > 0.0) requireBlurWithinLimit(o_.blurMm, bed.lattice());
    requireWithinBudget(estimatePhantomPeakBytes(bed, o_), global.memory, "phantom of " + input_);
    CommandProgress progress(global);
    const Grid<float> img = makePhantom(bed, o_, resolveThreads(global.threads), progress);
    std::ostringstream snr;
    snr << o_.snr;
    // Header keys let `voxpack ingest --void auto` pick the right polarity.
    const std::map<std::string, std::string> meta = {
        {"voxpack_version", versionString()},
        {"voxpack_source", input_},
        {"voxpack_modality", modality_},
        {"voxpack_void", o_.modality == Modality::Mri ? "bright" : "dark"},
        {"voxpack_snr", snr.str()},
        {"voxpack_seed", std::to_string(o_.seed)}};
    writeVolume(out, img, type, meta);
    if (!global.quiet) {
      const Lattice& l = img.lattice();
      std::cout << "wrote " << output_ << ": " << l.dims[0] << " x " << l.dims[1] << " x "
                << l.dims[2] << " voxels of " << l.spacingMm[2] << " mm (" << modality_ << ", SNR "
                << o_.snr << ")\n";
    }
    return 0;
  }

 private:
  std::string input_, output_, modality_, pixel_ = "float32";
  PhantomOptions o_;
};

}  // namespace

std::unique_ptr<Command> makePhantomCommand() { return std::make_unique<PhantomCommand>(); }

}  // namespace voxpack::app
