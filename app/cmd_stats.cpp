// voxpack stats IN.h5 -o STATS.json [--only ...] [--csv DIR] [--roi-mm Z0:Z1]: structure
// statistics of a bed, optionally of a region of interest.
#include <iostream>
#include <optional>
#include <sstream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/stats.hpp"

namespace voxpack::app {
namespace {

class StatsCommand final : public Command {
 public:
  std::string name() const override { return "stats"; }
  std::string description() const override { return "structure statistics of a bed"; }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("file", input_, "bed file (.h5)")->required();
    sub.add_option("-o,--output", output_, "statistics JSON to write")->required();
    sub.add_option("--only", only_,
                   "comma-separated statistics: axial,radial,s2,mes,psd,chords,shadow,"
                   "coordination,orientation (default: all)");
    roiZOpt_ = sub.add_option("--roi-mm", roiZ_,
                              "Z0:Z1: crop to the voxels whose centre z lies in [Z0, Z1] mm "
                              "(lattice world coordinates) before any statistic");
    roiBoxOpt_ =
        sub.add_option("--roi-box-mm", roiBox_,
                       "X0:X1,Y0:Y1,Z0:Z1: crop to a box in mm (an empty range keeps that axis)");
    roiBoxOpt_->excludes(roiZOpt_);
    sub.add_option("--csv", csvDir_, "also write one CSV per statistic into this folder");
    sub.add_option("--trim-mm", o_.trimMm,
                   "mm trimmed at each bed end for the axial statistics (default: 2 particle "
                   "diameters when known, else 0)");
    sub.add_option("--particle-diameter-mm", o_.particleDiameterMm,
                   "particle diameter (default: from the bed's particle table)");
    sub.add_option("--s2-max-lag-mm", o_.s2MaxLagMm,
                   "largest S2 lag (default: a quarter of the smallest extent, <= 64 voxels)");
    sub.add_flag("--s2-float", o_.s2Float, "S2 FFTs in single precision (faster, less exact)");
    sub.add_option("--radial-bin-mm", o_.radialBinMm, "annulus width (default: one voxel)");
    sub.add_option("--mes-method", o_.mesMethod,
                   "mean empty space: lattice (13 directions), isotropic (CGAL rays) or both")
        ->capture_default_str();
    sub.add_option("--mes-samples", o_.mesSamples, "void voxels sampled by the isotropic path")
        ->capture_default_str();
    sub.add_option("--mes-directions", o_.mesDirections, "ray directions per sampled voxel")
        ->capture_default_str();
    sub.add_option("--seed", o_.seed, "seed of the isotropic sampling")->capture_default_str();
  }
  int execute(const GlobalOptions& global) override {
    o_.only.clear();
    std::stringstream ss(only_);
    for (std::string item; std::getline(ss, item, ',');)
      if (!item.empty()) o_.only.insert(item);
    if (!only_.empty() && o_.only.empty()) throw UsageError("--only: no statistic named");
    o_.threads = resolveThreads(global.threads);
    // Parse the ROI before reading: a bad ROI must fail fast, without touching the file.
    std::optional<stats::CropOptions> roi;
    if (roiZOpt_->count() > 0) roi = stats::parseRoiZ(roiZ_);
    if (roiBoxOpt_->count() > 0) roi = stats::parseRoiBox(roiBox_);
    Bed bed = readBed(input_);
    nlohmann::json roiRecord = nullptr;
    if (roi) {
      stats::CropBox box;
      // Assigning frees the uncropped bed: statistics then run on the ROI alone.
      bed = stats::cropBed(bed, *roi, &box);
      roiRecord = stats::roiJson(*roi, box);
    }
    CommandProgress progress(global);
    nlohmann::json stats = stats::computeStats(bed, o_, progress);
    stats["roi_mm"] = roiRecord;
    stats["input"] = input_;
    stats["command_line"] = global.commandLine;
    stats["input_provenance"] = bed.provenance;
    if (!csvDir_.empty()) {
      stats::writeStatsCsv(stats, csvDir_);
      stats::writeShadowPngs(stats, csvDir_);
    }
    writeJsonFile(output_, stats);
    if (!global.quiet) std::cerr << "wrote " << output_ << '\n';
    return 0;
  }

 private:
  std::string input_, output_, only_, csvDir_, roiZ_, roiBox_;
  stats::StatsOptions o_;
  CLI::Option* roiZOpt_ = nullptr;
  CLI::Option* roiBoxOpt_ = nullptr;
};

}  // namespace

std::unique_ptr<Command> makeStatsCommand() { return std::make_unique<StatsCommand>(); }

}  // namespace voxpack::app
