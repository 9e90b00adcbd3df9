// voxpack._voxpack: the C++ side of the Python module (docs/python.md). It is not a second
// implementation: commands run through voxpack::app::runCommandLine (the CLI's own
// parsing and code), beds through core's readBed/writeBed, statistics of in-memory arrays
// through stats::computeStats, the function `voxpack stats` calls.
//
// Threads and the GIL: every long call runs with the GIL released. The progress hook
// takes the GIL only to call the Python callback (throttled) and, on the calling thread,
// to run PyErr_CheckSignals() so that Ctrl-C / KeyboardInterrupt cancels the work; the
// Python exception is kept and raised once the C++ call has unwound.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli.hpp"
#include "convert.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/parallel.hpp"
#include "voxpack/core/version.hpp"
#include "voxpack/stats/bed_stats.hpp"
#include "voxpack/stats/crop.hpp"
#include "voxpack/stats/profiles.hpp"
#include "voxpack/stats/stats.hpp"
#include "voxpack/stats/streamed.hpp"

namespace voxpack::python {
namespace {

using Clock = std::chrono::steady_clock;

// Progress hook bridging to Python. Constructed and destroyed with the GIL held; its
// methods run with the GIL released (they acquire it when they call into Python).
class PyProgress final : public Progress {
 public:
  PyProgress(py::object callback, py::object onMessage)
      : callback_(std::move(callback)),
        onMessage_(std::move(onMessage)),
        owner_(std::this_thread::get_id()) {}

  ~PyProgress() override {
    // Drop a pending error that nobody raised (GIL held here, see above).
    if (type_ || value_ || trace_) {
      Py_XDECREF(type_);
      Py_XDECREF(value_);
      Py_XDECREF(trace_);
    }
  }

  void report(std::string_view stage, double fraction) override {
    if (callback_.is_none() || cancel_.load()) return;
    const auto now = Clock::now();
    // Throttle: a callback at most every 0.1 s, but always a stage's start and end.
    const bool edge = fraction >= 1.0 || stage != lastStage_;
    if (!edge && now - lastReport_ < std::chrono::milliseconds(100)) return;
    lastReport_ = now;
    lastStage_ = std::string(stage);
    py::gil_scoped_acquire gil;
    try {
      callback_(fraction, py::str(std::string(stage)));
    } catch (py::error_already_set& e) {
      e.restore();
      keepPythonError();
    }
  }

  bool cancelled() const override {
    if (cancel_.load()) return true;
    if (std::this_thread::get_id() != owner_) return false;
    const auto now = Clock::now();
    if (now - lastSignalCheck_ < std::chrono::milliseconds(20)) return false;
    lastSignalCheck_ = now;
    py::gil_scoped_acquire gil;
    // Runs the Python signal handlers (main thread only): SIGINT raises KeyboardInterrupt.
    if (PyErr_CheckSignals() != 0) keepPythonError();
    return cancel_.load();
  }

  void message(std::string_view text) override {
    if (onMessage_.is_none() || cancel_.load()) return;
    py::gil_scoped_acquire gil;
    try {
      onMessage_(py::str(std::string(text)));
    } catch (py::error_already_set& e) {
      e.restore();
      keepPythonError();
    }
  }

  /// Raises the kept Python exception (KeyboardInterrupt, or the callback's), if any.
  /// GIL held.
  void raisePending() {
    if (!type_) return;
    PyErr_Restore(type_, value_, trace_);
    type_ = value_ = trace_ = nullptr;
    throw py::error_already_set();
  }

 private:
  // GIL held, Python error indicator set: keep the first error, ask the work to stop.
  void keepPythonError() const {
    if (!type_) {
      PyErr_Fetch(&type_, &value_, &trace_);
    } else {
      PyErr_Clear();
    }
    cancel_.store(true);
  }

  py::object callback_, onMessage_;
  std::thread::id owner_;
  mutable std::atomic<bool> cancel_{false};
  mutable Clock::time_point lastSignalCheck_{};
  Clock::time_point lastReport_{};
  std::string lastStage_;
  mutable PyObject* type_ = nullptr;
  mutable PyObject* value_ = nullptr;
  mutable PyObject* trace_ = nullptr;
};

// Runs `work` without the GIL; a Python exception kept by the hook wins over the C++
// exception the cancellation caused (Cancelled); other C++ exceptions propagate to the
// translators below.
template <class F>
auto runReleased(PyProgress& hook, F&& work) {
  std::exception_ptr error;
  std::optional<decltype(work())> result;
  {
    py::gil_scoped_release nogil;
    try {
      result.emplace(work());
    } catch (...) {
      error = std::current_exception();
    }
  }
  hook.raisePending();
  if (error) std::rethrow_exception(error);
  return std::move(*result);
}

int runCli(const std::vector<std::string>& args, py::object progress, py::object message) {
  PyProgress hook(std::move(progress), std::move(message));
  return runReleased(hook, [&] { return app::runCommandLine(args, &hook); });
}

// std::cout of the command (e.g. `export --json`) into a string. std::cout is
// process-wide: one capture at a time (the mutex), and output another thread's command
// prints meanwhile lands in the capture too (docs/python.md says so).
std::mutex coutCaptureMutex;

class CoutCapture {
 public:
  CoutCapture() : lock_(coutCaptureMutex), old_(std::cout.rdbuf(buffer_.rdbuf())) {}
  ~CoutCapture() {
    std::cout.flush();
    std::cout.rdbuf(old_);
  }
  CoutCapture(const CoutCapture&) = delete;
  CoutCapture& operator=(const CoutCapture&) = delete;
  std::string text() const { return buffer_.str(); }

 private:
  std::lock_guard<std::mutex> lock_;
  std::ostringstream buffer_;
  std::streambuf* old_;
};

py::tuple runCliCapture(const std::vector<std::string>& args, py::object progress,
                        py::object message) {
  PyProgress hook(std::move(progress), std::move(message));
  std::string text;
  const int code = runReleased(hook, [&] {
    CoutCapture capture;
    const int c = app::runCommandLine(args, &hook);
    std::cout.flush();
    text = capture.text();
    return c;
  });
  return py::make_tuple(code, py::bytes(text).attr("decode")("utf-8", "replace"));
}

py::dict readBedPy(const std::string& path) {
  Bed bed = [&] {
    py::gil_scoped_release nogil;
    return readBed(path);
  }();
  return bedToDict(std::move(bed));
}

void writeBedPy(const std::string& path, const py::dict& bedDict, int compressionLevel) {
  const Bed bed = bedFromDict(bedDict);
  BedWriteOptions o;
  o.compressionLevel = compressionLevel;
  py::gil_scoped_release nogil;
  writeBed(path, bed, o);
}

template <class T>
T option(const py::dict& d, const char* key, T fallback) {
  if (!d.contains(key) || d[key].is_none()) return fallback;
  return d[key].cast<T>();
}

// The body of `voxpack stats` (app/cmd_stats.cpp, its in-memory path) for an in-memory bed:
// the same option parsing and checks, the same ROI / bed-window / packed-region crops,
// computeStats and the same extra keys.
py::object statsPy(const py::object& bedArg, const py::dict& opt, py::object progress,
                   py::object message) {
  stats::StatsOptions o;
  if (opt.contains("only") && !opt["only"].is_none()) {
    for (auto item : opt["only"]) {
      const auto name = py::str(item).cast<std::string>();
      if (!name.empty()) o.only.insert(name);
    }
    if (o.only.empty()) throw UsageError("--only: no statistic named");
  }
  o.particleDiameterMm = option(opt, "particle_diameter_mm", o.particleDiameterMm);
  o.trimMm = option(opt, "trim_mm", o.trimMm);
  o.s2MaxLagMm = option(opt, "s2_max_lag_mm", o.s2MaxLagMm);
  o.s2Float = option(opt, "s2_float", o.s2Float);
  o.radialBinMm = option(opt, "radial_bin_mm", o.radialBinMm);
  o.mesMethod = option(opt, "mes_method", o.mesMethod);
  o.mesSamples = option(opt, "mes_samples", o.mesSamples);
  o.mesDirections = option(opt, "mes_directions", o.mesDirections);
  o.seed = option(opt, "seed", o.seed);
  o.threads = resolveThreads(option(opt, "threads", 0));
  std::optional<stats::CropOptions> roi;
  const auto roiZ = option<std::string>(opt, "roi_mm", "");
  const auto roiBox = option<std::string>(opt, "roi_box_mm", "");
  if (!roiZ.empty() && !roiBox.empty()) throw UsageError("--roi-box-mm excludes --roi-mm");
  if (!roiZ.empty()) roi = stats::parseRoiZ(roiZ);
  if (!roiBox.empty()) roi = stats::parseRoiBox(roiBox);
  const auto packedMode = option<std::string>(opt, "packed_region", "off");
  if (packedMode != "auto" && packedMode != "off")
    throw UsageError("--packed-region: " + packedMode + " not in {auto,off}");
  const bool packedAuto = packedMode == "auto";
  const bool window = option(opt, "bed_window", false);
  if (window) {
    if (!(o.particleDiameterMm > 0))
      throw UsageError(
          "--bed-window needs --particle-diameter-mm (the window is 2 d from "
          "each end)");
    if (roi || packedAuto)
      throw UsageError(
          "--bed-window cannot be combined with --roi-mm, --roi-box-mm or "
          "--packed-region auto");
  }
  const auto inputName = option<std::string>(opt, "input", "the array");

  // A bed dict is copied into core grids; a path is read straight into them (the CLI's
  // reader, no numpy round trip: one copy of the volumes in memory, not two).
  Bed bed = [&] {
    if (py::isinstance<py::str>(bedArg)) {
      const std::string path = bedArg.cast<std::string>();
      py::gil_scoped_release nogil;
      return readBed(path);
    }
    return bedFromDict(bedArg.cast<py::dict>());
  }();
  PyProgress hook(std::move(progress), std::move(message));
  nlohmann::json result = runReleased(hook, [&] {
    const nlohmann::json provenance = bed.provenance;
    stats::BedStatsRequest request;
    request.roi = roi;
    request.bedWindow = window;
    request.packedAuto = packedAuto;
    request.inputName = inputName;
    nlohmann::json s = stats::computeBedStats(std::move(bed), o, request, hook);
    s["input_provenance"] = provenance;
    sanitizeNonFinite(s);  // what writeJsonFile does before the CLI writes its file
    return s;
  });
  result["input"] = pythonToJson(opt.contains("input") ? py::object(opt["input"]) : py::none());
  result["command_line"] =
      pythonToJson(opt.contains("command_line") ? py::object(opt["command_line"]) : py::none());
  return jsonToPython(result);
}

py::list statisticNamesPy() {
  py::list out;
  for (const auto& n : stats::statisticNames()) out.append(n);
  return out;
}

}  // namespace
}  // namespace voxpack::python

PYBIND11_MODULE(_voxpack, m) {
  namespace py = pybind11;
  using namespace voxpack;
  using namespace voxpack::python;
  m.doc() = "C++ core of the voxpack package (use `import voxpack`, not this module).";

  // Exceptions: the CLI's exit-2 family are ValueError (OSError for files), with the
  // CLI's message; register bases first (pybind11 tries the latest translator first).
  static py::exception<InputError> inputError(m, "InputError", PyExc_ValueError);
  static py::exception<UsageError> usageError(m, "UsageError", inputError.ptr());
  static py::exception<FormatError> formatError(m, "FormatError", inputError.ptr());
  static py::exception<ResourceError> resourceError(m, "ResourceError", inputError.ptr());
  static py::exception<IoError> ioError(m, "IoError", PyExc_OSError);
  static py::exception<Cancelled> cancelled(m, "Cancelled", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const UsageError& e) {
      usageError(e.what());
    } catch (const FormatError& e) {
      formatError(e.what());
    } catch (const ResourceError& e) {
      resourceError(e.what());
    } catch (const InputError& e) {
      inputError(e.what());
    } catch (const IoError& e) {
      ioError(e.what());
    } catch (const Cancelled& e) {
      cancelled(e.what());
    }
  });

  m.def("version", &versionString, "voxpack version string (X.Y.Z).");
  m.def("run_cli", &runCli, py::arg("args"), py::arg("progress") = py::none(),
        py::arg("message") = py::none(),
        "Runs the voxpack command line in-process (args[0] is the program name); returns the "
        "exit code. progress(fraction, stage) and message(text) are called with the GIL.");
  m.def("run_cli_capture", &runCliCapture, py::arg("args"), py::arg("progress") = py::none(),
        py::arg("message") = py::none(),
        "As run_cli, and returns (exit code, what the command wrote to std::cout).");
  m.def("read_bed", &readBedPy, py::arg("path"),
        "Reads a bed file into a dict of numpy arrays that own the C++ storage.");
  m.def("write_bed", &writeBedPy, py::arg("path"), py::arg("bed"), py::arg("compression_level") = 4,
        "Writes a bed dict atomically.");
  m.def(
      "bed_datasets", [](const std::string& path) { return bedDatasets(path); }, py::arg("path"),
      "Datasets present in a bed file.");
  m.def("stats", &statsPy, py::arg("bed"), py::arg("options"), py::arg("progress") = py::none(),
        py::arg("message") = py::none(),
        "computeStats of a bed dict or a bed file path, as `voxpack stats`.");
  m.def("statistic_names", &statisticNamesPy, "Names accepted by only=.");
}
