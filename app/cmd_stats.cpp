// voxpack stats IN.h5 -o STATS.json [--only ...] [--csv DIR] [--roi-mm Z0:Z1]: structure
// statistics of a bed, optionally of a region of interest. The peak memory is estimated
// first: work that fits runs in memory, work that does not streams in z-slabs (axial,
// radial, S2, orientation), the rest is refused up front (docs/scale.md). Under mpirun
// (MPI builds) the slabs are spread over the ranks and rank 0 writes the JSON.
#include <cmath>
#include <iostream>
#include <optional>
#include <sstream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/stats/bed_stats.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/distributed.hpp"
#include "voxpack/stats/stats.hpp"
#include "voxpack/stats/streamed.hpp"

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
    sub.add_option("--s2-tile-voxels", o_.s2TileVoxels,
                   "streamed S2: cut each slab into y-x tiles this many voxels across (default: "
                   "whole planes when they fit --memory-limit, else the cheapest tile that does)")
        ->check(CLI::PositiveNumber);
    sub.add_option("--radial-bin-mm", o_.radialBinMm, "annulus width (default: one voxel)");
    sub.add_option("--mes-method", o_.mesMethod,
                   "mean empty space: lattice (13 directions), isotropic (CGAL rays) or both")
        ->capture_default_str();
    sub.add_option("--mes-samples", o_.mesSamples, "void voxels sampled by the isotropic path")
        ->capture_default_str();
    sub.add_option("--mes-directions", o_.mesDirections, "ray directions per sampled voxel")
        ->capture_default_str();
    sub.add_option("--seed", o_.seed, "seed of the isotropic sampling")->capture_default_str();
    sub.add_option("--slab-voxels", slabPlanes_,
                   "stream in z-slabs this many voxels (planes) thick, whatever the memory "
                   "(axial, radial, s2, chords, mes, orientation only; default: stream only "
                   "past --memory-limit)")
        ->check(CLI::PositiveNumber);
    sub.add_option("--mes-halo-planes", mesHalo_,
                   "streamed mean empty space: planes read beyond each side of a slab; runs "
                   "longer than the halo are cut and counted (default: the whole bed when it "
                   "fits --memory-limit, else twice the slab)")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--packed-region", packedMode_,
                   "auto: compute every statistic on the packed slices only (detected as "
                   "compare does); off: the whole bed (a warning when > 10 % is headspace)")
        ->check(CLI::IsMember({"auto", "off"}))
        ->capture_default_str();
    sub.add_flag("--bed-window", bedWindow_,
                 "crop to the bed's interior before any statistic: from 2 d above the lowest "
                 "mask slice to 2 d below the highest particle centre (d = "
                 "--particle-diameter-mm); the window of the headline densities "
                 "(docs/dem.md)");
  }
  int execute(const GlobalOptions& global) override {
    const stats::Communicator& comm = stats::Communicator::world();
    return runOnRanks(comm, [&] { return run(global, comm); });
  }

 private:
  std::string input_, output_, only_, csvDir_, roiZ_, roiBox_, packedMode_ = "off";
  std::int64_t slabPlanes_ = 0, mesHalo_ = -1;
  bool bedWindow_ = false;
  stats::StatsOptions o_;
  CLI::Option* roiZOpt_ = nullptr;
  CLI::Option* roiBoxOpt_ = nullptr;

  int run(const GlobalOptions& global, const stats::Communicator& comm) {
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
    const bool packedAuto = packedMode_ == "auto";
    if (bedWindow_) {
      if (!(o_.particleDiameterMm > 0))
        throw UsageError(
            "--bed-window needs --particle-diameter-mm (the window is 2 d from "
            "each end)");
      if (roi || packedAuto)
        throw UsageError(
            "--bed-window cannot be combined with --roi-mm, --roi-box-mm or "
            "--packed-region auto");
    }

    // The estimate comes from the header alone, before any volume is read.
    const BedHeader header = readBedHeader(input_);
    std::optional<VoxelBox> roiBox;
    if (roi) {
      const stats::CropBox cb = stats::cropBox(header.lattice, *roi);
      roiBox = VoxelBox{cb.first, cb.dims};
    }
    const std::uint64_t inMemory = stats::estimateInMemoryBytes(header, o_, roiBox);
    const bool forced = slabPlanes_ > 0 || comm.size() > 1;
    const bool stream = forced || !global.memory.fits(inMemory);
    if (stream && bedWindow_)
      throw UsageError(
          "--bed-window works on the in-memory path only; use --roi-mm Z0:Z1 "
          "to stream a window");
    const std::set<std::string> which = o_.only.empty() ? stats::statisticNames() : o_.only;
    std::string cannot;
    for (const auto& s : which)
      if (!stats::streamableStatistics().count(s)) cannot += (cannot.empty() ? "" : ",") + s;
    if (stream && !cannot.empty()) {
      if (!forced)
        requireWithinBudget(inMemory, global.memory,
                            input_ + ": stats in memory (" + cannot +
                                " cannot stream; --only axial,radial,s2,chords,mes,orientation "
                                "can)");
      throw UsageError(
          std::string(slabPlanes_ > 0 ? "--slab-voxels" : "mpirun") + ": " + cannot +
          " cannot be streamed in slabs; pass --only with axial,radial,s2,chords,mes,orientation");
    }

    CommandProgress bar(global);
    // Every statistic's start is a poll (the library polls inside a few only).
    StopAtStageProgress progress(bar);
    nlohmann::json stats;
    if (stream) {
      stats::StreamOptions so;
      so.slabPlanes = slabPlanes_;
      so.mesHaloPlanes = mesHalo_;
      so.budget = global.memory;
      so.roi = roi;
      so.packedRegion = packedAuto;
      stats = stats::computeStatsStreamed(input_, o_, so, progress, comm);
    } else {
      stats = inMemory_(global, roi, packedAuto, progress);
    }
    stats["memory_estimate_bytes"] = {{"in_memory", inMemory},
                                      {"limit", global.memory.limitBytes},
                                      {"path", stream ? "streamed" : "in_memory"}};
    stats["input"] = input_;
    stats["command_line"] = global.commandLine;
    stats["input_provenance"] = header.provenance;
    if (comm.rank() != 0) return 0;
    progress.poll("stats: before writing " + output_);
    if (!csvDir_.empty()) {
      stats::writeStatsCsv(stats, csvDir_);
      stats::writeShadowPngs(stats, csvDir_);
    }
    writeJsonFile(output_, stats);
    if (!global.quiet) std::cerr << "wrote " << output_ << '\n';
    return 0;
  }

  nlohmann::json inMemory_(const GlobalOptions& global,
                           const std::optional<stats::CropOptions>& roi, bool packedAuto,
                           Progress& progress) {
    stats::BedStatsRequest request;
    request.roi = roi;
    request.bedWindow = bedWindow_;
    request.packedAuto = packedAuto;
    request.inputName = input_;
    return stats::computeBedStats(readBed(input_, global.memory), o_, request, progress);
  }
};

}  // namespace

std::unique_ptr<Command> makeStatsCommand() { return std::make_unique<StatsCommand>(); }

}  // namespace voxpack::app
