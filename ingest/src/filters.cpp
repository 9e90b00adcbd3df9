// Median filter (ours: a fixed small window is faster than ITK's generic one) and the
// Grid-side wrappers of the ITK filters in itk_filters.cpp.
#include "voxpack/ingest/filters.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "itk_bridge.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/segment.hpp"

namespace voxpack::ingest {
namespace {

template <class T>
bridge::Raw<T> toRaw(const Grid<T>& g) {
  bridge::Raw<T> r;
  r.dims = g.lattice().dims;
  r.spacing = g.lattice().spacingMm;
  r.origin = g.lattice().originMm;
  r.data = g.values();
  return r;
}

}  // namespace

float boxMedianAt(const Grid<float>& image, int r, std::int64_t k, std::int64_t j, std::int64_t i,
                  std::vector<float>& window) {
  const Lattice& l = image.lattice();
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  window.clear();
  for (std::int64_t c = -r; c <= r; ++c) {
    const std::int64_t kk = std::clamp<std::int64_t>(k + c, 0, nz - 1);
    for (std::int64_t b = -r; b <= r; ++b) {
      const std::int64_t jj = std::clamp<std::int64_t>(j + b, 0, ny - 1);
      const float* row = image.data() + l.offset(kk, jj, 0);
      for (std::int64_t a = -r; a <= r; ++a)
        window.push_back(row[std::clamp<std::int64_t>(i + a, 0, nx - 1)]);
    }
  }
  auto mid = window.begin() + static_cast<std::ptrdiff_t>(window.size() / 2);
  std::nth_element(window.begin(), mid, window.end());
  return *mid;
}

Grid<float> medianFilter(const Grid<float>& image, int r, int threads) {
  if (r < 1 || r > 5) throw InputError("median radius must be 1..5 voxels");
  const Lattice& l = image.lattice();
  Grid<float> out(l);
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
#pragma omp parallel num_threads(std::max(1, threads))
  {
    std::vector<float> window;
    window.reserve(static_cast<std::size_t>((2 * r + 1) * (2 * r + 1) * (2 * r + 1)));
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t k = 0; k < nz; ++k)
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i < nx; ++i) out(k, j, i) = boxMedianAt(image, r, k, j, i, window);
  }
  return out;
}

Grid<float> crossMedianFilter(const Grid<float>& image, int threads) {
  const Lattice& l = image.lattice();
  Grid<float> out(l);
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(dynamic, 1)
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) out(k, j, i) = crossMedianAt(image, k, j, i);
  return out;
}

void curvatureDiffusion(Grid<float>& image, const CurvatureDiffusionOptions& o, int threads) {
  if (o.iterations < 1 || o.iterations > 100)
    throw InputError("curvature diffusion iterations must be 1..100");
  if (!(o.conductance > 0.0)) throw InputError("curvature diffusion conductance must be > 0");
  if (!(o.timeStepFraction > 0.0 && o.timeStepFraction <= 1.0))
    throw InputError("curvature diffusion time-step fraction must be in (0, 1]");
  auto raw = toRaw(image);
  // Stability limit of the explicit scheme in 3-D on unit spacing: 1 / 2^(d+1) = 0.0625.
  bridge::curvatureDiffusion(raw, o.iterations, o.conductance, 0.0625 * o.timeStepFraction,
                             threads);
  image.values() = std::move(raw.data);
}

std::size_t richardsonLucy(Grid<float>& image, double sigmaMm, int iterations, int threads) {
  if (iterations < 1 || iterations > 200)
    throw InputError("deconvolution iterations must be 1..200");
  if (!(sigmaMm > 0.0) || !std::isfinite(sigmaMm))
    throw InputError("deconvolution: the point-spread sigma must be > 0 mm");
  auto raw = toRaw(image);
  std::size_t clipped = 0;
  double sum = 0;
  for (float& v : raw.data) {
    if (v < 0.0f) {
      v = 0.0f;
      ++clipped;
    }
    sum += v;
  }
  // A small constant keeps every blurred estimate > 0 (the update divides by it); the blur
  // maps a constant to itself, so it is taken off afterwards.
  const auto offset = static_cast<float>(
      1e-2 * sum / static_cast<double>(std::max<std::size_t>(1, raw.data.size())) + 1e-6);
  for (float& v : raw.data) v += offset;
  const Lattice& l = image.lattice();
  bridge::richardsonLucy(
      raw, {sigmaMm / l.spacingMm[0], sigmaMm / l.spacingMm[1], sigmaMm / l.spacingMm[2]},
      iterations, threads);
  for (float& v : raw.data) v -= offset;
  image.values() = std::move(raw.data);
  return clipped;
}

double n4BiasCorrection(Grid<float>& image, const N4Options& o, int threads, Progress& progress) {
  if (o.shrinkFactor < 1 || o.shrinkFactor > 16) throw InputError("N4 shrink factor must be 1..16");
  if (o.fittingLevels < 1 || o.fittingLevels > 6)
    throw InputError("N4 fitting levels must be 1..6");
  if (o.iterationsPerLevel < 1) throw InputError("N4 iterations per level must be >= 1");
  if (o.controlPoints < 4) throw InputError("N4 control points must be >= 4");
  progress.report("bias correction (N4)", 0.0);
  // The field is fitted on the bright phase only (MRI water): voxels without signal hold
  // pure noise, whose logarithm would drag the field.
  const double t = otsuThreshold(image);
  std::vector<std::uint8_t> mask(image.size());
  for (std::size_t n = 0; n < image.size(); ++n) mask[n] = image[n] > t && image[n] > 0.0f;
  auto raw = toRaw(image);
  // N4 takes logarithms: keep every intensity positive.
  float top = 0.0f;
  for (float v : raw.data) top = std::max(top, v);
  const float floor = 1e-6f * std::max(1.0f, top);
  for (float& v : raw.data) v = std::max(v, floor);
  const double logRange = bridge::n4(raw, mask, o.shrinkFactor, o.fittingLevels,
                                     o.iterationsPerLevel, o.convergence, o.controlPoints, threads);
  // Voxels that were clamped to the floor keep their original (non-positive) value scaled.
  for (std::size_t n = 0; n < image.size(); ++n)
    if (image[n] > floor) image[n] = raw.data[n];
  progress.report("bias correction (N4)", 1.0);
  return std::exp(logRange);
}

Grid<std::uint32_t> watershedLabels(const Grid<std::uint8_t>& indicator, double markerDepthVoxels,
                                    int threads, std::size_t* labelCount) {
  if (!(markerDepthVoxels >= 0.0)) throw InputError("watershed marker depth must be >= 0");
  bridge::Raw<std::uint8_t> solid = toRaw(indicator);
  for (auto& v : solid.data) v = v == 0 ? 1 : 0;
  const std::vector<std::uint32_t> basins = bridge::watershed(solid, markerDepthVoxels, threads);
  Grid<std::uint32_t> labels(indicator.lattice(), 0);
  // Basins reach into the void: cut them to the solid, renumber 1..N in scan order.
  std::unordered_map<std::uint32_t, std::uint32_t> remap;
  for (std::size_t n = 0; n < indicator.size(); ++n) {
    if (indicator[n] != 0 || basins[n] == 0) continue;
    auto [it, inserted] =
        remap.try_emplace(basins[n], static_cast<std::uint32_t>(remap.size() + 1));
    labels[n] = it->second;
  }
  if (labelCount) *labelCount = remap.size();
  return labels;
}

}  // namespace voxpack::ingest
