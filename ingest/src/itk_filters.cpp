// ITK-backed filters behind the plain bridge: curvature anisotropic diffusion,
// Richardson-Lucy deconvolution, N4 bias correction, distance-map watershed. The second (and last)
// ITK translation unit.
#include <itkBSplineControlPointImageFilter.h>
#include <itkCurvatureAnisotropicDiffusionImageFilter.h>
#include <itkImage.h>
#include <itkMorphologicalWatershedImageFilter.h>
#include <itkN4BiasFieldCorrectionImageFilter.h>
#include <itkRichardsonLucyDeconvolutionImageFilter.h>
#include <itkShrinkImageFilter.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include <algorithm>
#include <cmath>

#include "itk_convert.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::ingest::bridge {
namespace {

using FloatImage = itk::Image<float, 3>;
using MaskImage = itk::Image<unsigned char, 3>;
using LabelImage = itk::Image<std::uint32_t, 3>;

}  // namespace

void curvatureDiffusion(Raw<float>& image, int iterations, double conductance, double timeStep,
                        int threads) {
  auto img = toItk<float>(image, false);
  auto f = itk::CurvatureAnisotropicDiffusionImageFilter<FloatImage, FloatImage>::New();
  f->SetInput(img);
  f->SetNumberOfIterations(static_cast<unsigned>(iterations));
  f->SetTimeStep(timeStep);
  f->SetConductanceParameter(conductance);
  f->SetNumberOfWorkUnits(static_cast<itk::ThreadIdType>(std::max(1, threads)));
  try {
    f->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InternalError("curvature diffusion failed: " + itkMessage(e));
  }
  const float* out = f->GetOutput()->GetBufferPointer();
  std::copy(out, out + image.data.size(), image.data.begin());
}

void richardsonLucy(Raw<float>& image, const std::array<double, 3>& sigma, int iterations,
                    int threads) {
  auto img = toItk<float>(image, false);
  // The kernel on the voxel grid out to 3 sigma, summing to 1 (so the deconvolution keeps
  // the image's total, as the blur does).
  auto kernel = FloatImage::New();
  FloatImage::SizeType size;
  int half[3];
  for (unsigned d = 0; d < 3; ++d) {
    half[d] = static_cast<int>(std::ceil(3.0 * sigma[2 - d]));
    size[d] = static_cast<itk::SizeValueType>(2 * half[d] + 1);
  }
  kernel->SetRegions(FloatImage::RegionType(size));
  kernel->Allocate();
  float* kv = kernel->GetBufferPointer();
  double total = 0;
  std::size_t at = 0;
  for (int z = -half[2]; z <= half[2]; ++z)
    for (int y = -half[1]; y <= half[1]; ++y)
      for (int x = -half[0]; x <= half[0]; ++x) {
        double e = 0;
        const int r[3] = {x, y, z};
        for (unsigned d = 0; d < 3; ++d)
          if (sigma[2 - d] > 0) e += 0.5 * r[d] * r[d] / (sigma[2 - d] * sigma[2 - d]);
        const double v = std::exp(-e);
        kv[at++] = static_cast<float>(v);
        total += v;
      }
  for (std::size_t n = 0; n < at; ++n) kv[n] = static_cast<float>(kv[n] / total);
  using Filter = itk::RichardsonLucyDeconvolutionImageFilter<FloatImage, FloatImage, FloatImage>;
  auto f = Filter::New();
  f->SetInput(img);
  f->SetKernelImage(kernel);
  f->SetNumberOfIterations(static_cast<unsigned>(iterations));
  f->NormalizeOn();
  f->SetNumberOfWorkUnits(static_cast<itk::ThreadIdType>(std::max(1, threads)));
  try {
    f->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InternalError("Richardson-Lucy deconvolution failed: " + itkMessage(e));
  }
  const float* out = f->GetOutput()->GetBufferPointer();
  std::copy(out, out + image.data.size(), image.data.begin());
}

double n4(Raw<float>& image, const std::vector<std::uint8_t>& maskValues, int shrinkFactor,
          int levels, int iterationsPerLevel, double convergence, int controlPoints, int threads) {
  auto img = toItk<float>(image, true);
  Raw<std::uint8_t> maskRaw;
  maskRaw.dims = image.dims;
  maskRaw.spacing = image.spacing;
  maskRaw.origin = image.origin;
  maskRaw.data = maskValues;
  auto mask = toItk<unsigned char>(maskRaw, true);
  const auto tc = static_cast<itk::ThreadIdType>(std::max(1, threads));

  auto shrink = itk::ShrinkImageFilter<FloatImage, FloatImage>::New();
  shrink->SetInput(img);
  shrink->SetShrinkFactors(static_cast<unsigned>(shrinkFactor));
  shrink->SetNumberOfWorkUnits(tc);
  auto shrinkMask = itk::ShrinkImageFilter<MaskImage, MaskImage>::New();
  shrinkMask->SetInput(mask);
  shrinkMask->SetShrinkFactors(static_cast<unsigned>(shrinkFactor));

  using N4 = itk::N4BiasFieldCorrectionImageFilter<FloatImage, MaskImage, FloatImage>;
  auto f = N4::New();
  f->SetInput(shrink->GetOutput());
  f->SetMaskImage(shrinkMask->GetOutput());
  N4::VariableSizeArrayType iters(static_cast<unsigned>(levels));
  iters.Fill(static_cast<unsigned>(iterationsPerLevel));
  f->SetMaximumNumberOfIterations(iters);
  f->SetNumberOfFittingLevels(static_cast<unsigned>(levels));
  f->SetConvergenceThreshold(convergence);
  N4::ArrayType cp;
  cp.Fill(static_cast<unsigned>(controlPoints));
  f->SetNumberOfControlPoints(cp);
  f->SetNumberOfWorkUnits(tc);
  try {
    f->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InputError("N4 bias correction failed: " + itkMessage(e));
  }
  // The field lives on a B-spline control lattice in physical space: evaluate it at full
  // resolution instead of upsampling the shrunk result.
  using ControlLattice = N4::BiasFieldControlPointLatticeType;
  using ScalarImage = N4::ScalarImageType;
  auto bspliner = itk::BSplineControlPointImageFilter<ControlLattice, ScalarImage>::New();
  bspliner->SetInput(f->GetLogBiasFieldControlPointLattice());
  bspliner->SetSplineOrder(f->GetSplineOrder());
  bspliner->SetSize(img->GetLargestPossibleRegion().GetSize());
  bspliner->SetOrigin(img->GetOrigin());
  bspliner->SetSpacing(img->GetSpacing());
  bspliner->SetDirection(img->GetDirection());
  bspliner->SetNumberOfWorkUnits(tc);
  try {
    bspliner->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InternalError("N4 field reconstruction failed: " + itkMessage(e));
  }
  const auto* field = bspliner->GetOutput()->GetBufferPointer();
  double lo = 1e300, hi = -1e300;
  for (std::size_t n = 0; n < image.data.size(); ++n) {
    const double logb = field[n][0];
    lo = std::min(lo, logb);
    hi = std::max(hi, logb);
    image.data[n] = static_cast<float>(image.data[n] / std::exp(logb));
  }
  return hi - lo;
}

std::vector<std::uint32_t> watershed(const Raw<std::uint8_t>& solid, double level, int threads) {
  const auto tc = static_cast<itk::ThreadIdType>(std::max(1, threads));
  auto img = toItk<unsigned char>(solid, false);
  auto dist = itk::SignedMaurerDistanceMapImageFilter<MaskImage, FloatImage>::New();
  dist->SetInput(img);
  dist->SetInsideIsPositive(false);  // particle centres become the deepest minima
  dist->SetUseImageSpacing(false);
  dist->SetSquaredDistance(false);
  dist->SetBackgroundValue(0);
  dist->SetNumberOfWorkUnits(tc);
  auto ws = itk::MorphologicalWatershedImageFilter<FloatImage, LabelImage>::New();
  ws->SetInput(dist->GetOutput());
  ws->SetLevel(static_cast<float>(level));
  ws->SetMarkWatershedLine(false);
  ws->SetFullyConnected(true);
  try {
    ws->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InternalError("watershed failed: " + itkMessage(e));
  }
  const std::uint32_t* w = ws->GetOutput()->GetBufferPointer();
  return std::vector<std::uint32_t>(w, w + solid.data.size());
}

}  // namespace voxpack::ingest::bridge
