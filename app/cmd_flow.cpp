// voxpack flow IN.h5 -o FLOW.json [--axis z|y|x] [--periodic] [--tolerance T]
// [--max-steps N] [--field OUT.h5] [--csv DIR] [--roi-mm Z0:Z1] [--velocity-mm-s V]
// [--walls halfway|interpolated] [--no-mass-correction]:
// permeability, tortuosity and pressure drop of a bed by lattice Boltzmann.
#include <iostream>

#include "command.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/flow/flow.hpp"

namespace voxpack::app {
namespace {

class FlowCommand final : public Command {
 public:
  std::string name() const override { return "flow"; }
  std::string description() const override {
    return "permeability, tortuosity and pressure drop by lattice Boltzmann";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("file", input_, "bed file (.h5)")->required();
    sub.add_option("-o,--output", output_, "flow JSON to write")->required();
    sub.add_option("--axis", axis_, "flow axis: z, y or x")
        ->check(CLI::IsMember({"z", "y", "x"}))
        ->capture_default_str();
    sub.add_flag("--periodic", o_.periodic,
                 "every axis periodic (unit cells, periodic samples); default: walls across "
                 "the flow and fluid reservoirs along it");
    sub.add_flag("--mirror", mirror_,
                 "close the ends with the mirrored sample instead of reservoirs");
    sub.add_option("--reservoir-layers", o_.reservoirLayers,
                   "fluid layers before and after the sample (0: 0.6 particle diameters, at "
                   "least 4)")
        ->capture_default_str();
    sub.add_option("--tolerance", o_.lbm.tolerance,
                   "stop when the mean velocity changes by less than this per check")
        ->capture_default_str();
    sub.add_option("--max-steps", o_.lbm.maxSteps, "stop after this many time steps")
        ->capture_default_str();
    sub.add_option("--check-interval", o_.lbm.checkInterval, "steps between convergence checks")
        ->capture_default_str();
    sub.add_option("--tau", o_.lbm.tauPlus,
                   "TRT symmetric relaxation time (> 0.5; k does not depend on it)")
        ->capture_default_str();
    sub.add_flag("--double", double_, "store the populations in float64 (default float32)");
    sub.add_option("--field", field_, "write velocity and pressure to this HDF5 bed file");
    sub.add_option("--csv", csvDir_, "write radial_profile.csv and convergence.csv here");
    roiOpt_ = sub.add_option("--roi-mm", roi_,
                             "Z0:Z1: only the layers whose centre z lies in [Z0, Z1] mm");
    sub.add_option("--velocity-mm-s", o_.velocityMmS,
                   "superficial velocity for the pressure gradients (mm/s)")
        ->capture_default_str();
    sub.add_option("--viscosity-pa-s", o_.viscosityPaS, "fluid viscosity (Pa s)")
        ->capture_default_str();
    sub.add_option("--density-kg-m3", o_.densityKgM3, "fluid density (kg/m3)")
        ->capture_default_str();
    sub.add_option("--walls", walls_,
                   "halfway: bounce-back on the voxels; interpolated: links cut at the exact "
                   "surfaces of the particle table and the container (keep --tau <= 1)")
        ->check(CLI::IsMember({"halfway", "interpolated"}))
        ->capture_default_str();
    sub.add_flag("--no-mass-correction", noMassCorrection_,
                 "interpolated walls: let the mass drift instead of restoring it at each check");
    sub.add_option("--particle-diameter-mm", o_.particleDiameterMm,
                   "d for the correlations (default: spheres' d from the particle table, "
                   "else 6(1-eps)/S_v)");
  }
  int execute(const GlobalOptions& global) override {
    o_.axis = axis_ == "z" ? 0 : axis_ == "y" ? 1 : 2;
    o_.inflow = mirror_ ? flow::Inflow::Mirror : flow::Inflow::Reservoirs;
    if (mirror_ && o_.periodic) throw UsageError("--mirror and --periodic exclude each other");
    if (!(o_.velocityMmS > 0)) throw UsageError("--velocity-mm-s must be positive");
    if (!(o_.viscosityPaS > 0) || !(o_.densityKgM3 > 0))
      throw UsageError("--viscosity-pa-s and --density-kg-m3 must be positive");
    if (o_.lbm.checkInterval < 1) throw UsageError("--check-interval must be at least 1");
    o_.walls = walls_ == "interpolated" ? flow::Walls::Interpolated : flow::Walls::Halfway;
    o_.lbm.massCorrection = !noMassCorrection_;
    o_.lbm.precision = double_ ? flow::Precision::Double : flow::Precision::Float;
    o_.lbm.threads = resolveThreads(global.threads);
    std::optional<std::pair<double, double>> roi;
    if (roiOpt_->count() > 0) roi = flow::parseRoiMm(roi_);
    Bed bed = readBed(input_);
    nlohmann::json roiRecord = nullptr;
    if (roi) {
      bed = flow::cropBedZ(bed, roi->first, roi->second);
      roiRecord = {{"z0", roi->first},
                   {"z1", roi->second},
                   {"layers", bed.lattice().nz()},
                   {"origin_z_mm", bed.lattice().originMm[0]}};
    }
    CommandProgress progress(global);
    flow::FlowReport rep = flow::computeFlow(bed, o_, global.memory, progress);
    rep.json["roi_mm"] = roiRecord;
    rep.json["input"] = input_;
    rep.json["command_line"] = global.commandLine;
    rep.json["input_provenance"] = bed.provenance;
    if (!field_.empty()) {
      if (rep.json["status"] == "blocked")
        progress.message("flow: blocked, no field written");
      else
        flow::writeFlowField(field_, bed, rep);
    }
    if (!csvDir_.empty()) flow::writeFlowCsv(rep.json, csvDir_);
    writeJsonFile(output_, rep.json);
    if (!global.quiet)
      std::cerr << "flow: " << rep.json["status"].get<std::string>()
                << ", k = " << rep.json["permeability_mm2"].get<double>() << " mm^2, "
                << rep.json["steps"] << " steps; wrote " << output_ << '\n';
    return 0;
  }

 private:
  std::string input_, output_, axis_ = "z", field_, csvDir_, roi_, walls_ = "halfway";
  bool mirror_ = false, double_ = false, noMassCorrection_ = false;
  flow::FlowOptions o_;
  CLI::Option* roiOpt_ = nullptr;
};

}  // namespace

std::unique_ptr<Command> makeFlowCommand() { return std::make_unique<FlowCommand>(); }

}  // namespace voxpack::app
