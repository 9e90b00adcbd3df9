// voxpack compare --reference REF.h5 CAND.h5 [CAND.h5 ...] -o DIR: statistics of each bed,
// distances of each candidate to the reference, and a self-contained HTML report.
#include <cstdlib>
#include <iostream>
#include <set>

#include "command.hpp"
#include "voxpack/compare/compare.hpp"
#include "voxpack/compare/report.hpp"
#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/core/version.hpp"

namespace voxpack::app {
namespace {

class CompareCommand final : public Command {
 public:
  std::string name() const override { return "compare"; }
  std::string description() const override {
    return "compare simulated beds with a reference bed: statistics, distances, HTML report";
  }
  void addSwitches(CLI::App& sub) override {
    sub.add_option("--reference,-r", reference_, "reference bed (.h5), e.g. an ingested image")
        ->required();
    sub.add_option("candidates", candidates_, "candidate beds (.h5) compared with the reference")
        ->required();
    sub.add_option("-o,--output", output_, "report folder (created when missing)")->required();
    sub.add_option("--particle-diameter", particleDiameterMm_,
                   "particle diameter (mm) for end trimming and wall distances; 0 = infer")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--trim-mm", trimMm_,
                   "mm trimmed at each bed end for the axial statistics; < 0 = default");
    sub.add_option("--s2-max-lag-mm", s2MaxLagMm_, "largest S2 lag (mm); 0 = default")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--radial-step-mm", radialStepMm_,
                   "step of the common wall-distance grid (mm); 0 = the coarser bed's")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--s2-step-mm", s2StepMm_,
                   "step of the common S2 lag grid (mm); 0 = the coarser bed's")
        ->check(CLI::NonNegativeNumber);
    sub.add_option("--bed-fraction", bedFraction_,
                   "packed region: slices denser than this fraction of the densest slice "
                   "(0 = whole bed; default 0.5)")
        ->check(CLI::Range(0.0, 1.0));
    sub.add_flag("--no-figures", noFigures_, "numbers and CSV files only (no matplotlib)");
    sub.add_option("--python", python_,
                   "python with matplotlib for the figures (default $VOXPACK_PYTHON or "
                   "/usr/bin/python3)");
    sub.add_option("--figure-script", figureScript_,
                   "figure script to use instead of the built-in make_figures.py");
    sub.add_flag("--flow", flow_,
                 "also run the flow solver on every bed (packed region): permeability, "
                 "tortuosity and wall-flow share against the reference, radial velocity figure");
    flowOpts_[0] =
        sub.add_option("--flow-tolerance", flowTolerance_,
                       "flow: stop when the mean velocity changes by less than this per check")
            ->capture_default_str();
    flowOpts_[1] =
        sub.add_option("--flow-max-steps", flowMaxSteps_, "flow: stop after this many time steps")
            ->capture_default_str();
    flowOpts_[2] =
        sub.add_option(
               "--flow-walls", flowWalls_,
               "flow: halfway (bounce-back on the voxels) or interpolated (links cut at the "
               "exact surfaces of each bed's particle table and container)")
            ->check(CLI::IsMember({"halfway", "interpolated"}))
            ->capture_default_str();
  }

  int execute(const GlobalOptions& global) override {
    namespace fs = std::filesystem;
    for (const auto& p : std::vector<std::string>{reference_}) checkReadable(p, "--reference");
    for (const auto& p : candidates_) checkReadable(p, "candidate");
    if (!figureScript_.empty()) checkReadable(figureScript_, "--figure-script");
    std::error_code ec;
    const bool folderExisted = fs::exists(output_, ec);
    ensureWritableDirectory(output_, true);
    std::set<fs::path> before;
    for (const auto& e : fs::directory_iterator(output_)) before.insert(e.path());
    // Interrupted, compare leaves the folder as it found it: the files it added go, and the
    // folder when it made it (a file it replaced keeps its new content).
    try {
      return run(global);
    } catch (const Cancelled&) {
      std::vector<fs::path> added;
      for (const auto& e : fs::directory_iterator(output_, ec))
        if (!before.count(e.path())) added.push_back(e.path());
      for (const auto& p : added) fs::remove_all(p, ec);
      if (!folderExisted) fs::remove(output_, ec);
      throw;
    }
  }

 private:
  int run(const GlobalOptions& global) {
    namespace fs = std::filesystem;
    CommandProgress bar(global);
    // Every stage start of the statistics is a poll (the library polls only inside the mean
    // empty space); the report is written whole, then the stop request is honoured.
    StopAtStageProgress progress(bar);
    compare::CompareOptions opt;
    opt.stats.particleDiameterMm = particleDiameterMm_;
    opt.stats.trimMm = trimMm_;
    opt.stats.s2MaxLagMm = s2MaxLagMm_;
    opt.stats.threads = resolveThreads(global.threads);
    opt.radialGrid.gridStepMm = radialStepMm_;
    opt.bedRegionFraction = bedFraction_;
    opt.s2Grid.gridStepMm = s2StepMm_;
    for (const CLI::Option* fo : flowOpts_)
      if (!flow_ && fo->count() > 0) throw UsageError(fo->get_name() + " needs --flow");
    if (flow_) {
      if (!(flowTolerance_ > 0)) throw UsageError("--flow-tolerance must be positive");
      if (flowMaxSteps_ < 1) throw UsageError("--flow-max-steps must be at least 1");
      opt.flow.enabled = true;
      opt.flow.solver.lbm.tolerance = flowTolerance_;
      opt.flow.solver.lbm.maxSteps = flowMaxSteps_;
      opt.flow.solver.lbm.threads = opt.stats.threads;
      opt.flow.solver.walls =
          flowWalls_ == "interpolated" ? flow::Walls::Interpolated : flow::Walls::Halfway;
      opt.flow.memory = global.memory;
    }
    std::vector<fs::path> cands(candidates_.begin(), candidates_.end());
    const compare::Comparison c = compare::compareBedFiles(reference_, cands, opt, progress);

    compare::ReportOptions ro;
    if (!python_.empty()) {
      ro.python = python_;
    } else if (const char* env = std::getenv("VOXPACK_PYTHON"); env && *env) {
      ro.python = env;
    }
    ro.figureScript = figureScript_;
    ro.figures = !noFigures_;
    nlohmann::json inputs = {{"reference", reference_}, {"candidates", candidates_}};
    ro.summaryExtras = {{"voxpack_version", versionString()},
                        {"command_line", global.commandLine},
                        {"inputs", inputs},
                        {"options",
                         {{"particle_diameter_mm", particleDiameterMm_},
                          {"trim_mm", trimMm_},
                          {"s2_max_lag_mm", s2MaxLagMm_},
                          {"radial_step_mm", radialStepMm_},
                          {"s2_step_mm", s2StepMm_},
                          {"bed_fraction", bedFraction_},
                          {"threads", opt.stats.threads},
                          {"figures", !noFigures_},
                          {"flow", flow_},
                          {"flow_tolerance", flowTolerance_},
                          {"flow_max_steps", flowMaxSteps_},
                          {"flow_walls", flowWalls_}}},
                        {"methods",
                         {{"density",
                           "mean/std of slice packing densities (stats axial block); rel diff = "
                           "(candidate - reference) / reference"},
                          {"axial_ks_p",
                           "two-sample two-sided KS test of the slice densities; exact null "
                           "distribution (no ties) when n*m <= 4e6, else asymptotic Kolmogorov"},
                          {"radial_rmse",
                           "RMSE of density vs wall distance, linear interpolation onto a "
                           "uniform common grid (mm) over the overlapping range"},
                          {"s2_rmse", "RMSE of S2 vs lag, same common-grid scheme (mm)"},
                          {"mes_ks", "sup |F_ref - F_cand| of the binned mean-empty-space CDFs"}}}};
    progress.poll("compare: before the report");
    const compare::ReportResult r = compare::writeReport(output_, c, ro, bar);
    progress.poll("compare: report written");
    for (const auto& w : r.warnings) progress.message("warning: " + w);
    if (!r.warnings.empty() && global.quiet)
      for (const auto& w : r.warnings)
        if (w.find("figures skipped") != std::string::npos) std::cerr << "warning: " << w << '\n';
    std::cout << compare::formatTable(c) << compare::flowTextTable(c)
              << "summary: " << r.summaryJson.string() << '\n'
              << "report:  " << fs::absolute(r.indexHtml).string() << '\n';
    return 0;
  }

  static void checkReadable(const std::string& p, const char* what) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec))
      throw InputError(std::string(what) + " " + p + ": no such file");
  }

  std::string reference_;
  std::vector<std::string> candidates_;
  std::string output_;
  double particleDiameterMm_ = 0.0;
  double trimMm_ = -1.0;
  double s2MaxLagMm_ = 0.0;
  double radialStepMm_ = 0.0;
  double s2StepMm_ = 0.0;
  double bedFraction_ = 0.5;
  bool noFigures_ = false;
  bool flow_ = false;
  double flowTolerance_ = 1e-5;
  std::int64_t flowMaxSteps_ = 200000;
  std::string flowWalls_ = "halfway";
  CLI::Option* flowOpts_[3] = {nullptr, nullptr, nullptr};
  std::string python_;
  std::string figureScript_;
};

}  // namespace

std::unique_ptr<Command> makeCompareCommand() { return std::make_unique<CompareCommand>(); }

}  // namespace voxpack::app
