#pragma once
// Helpers shared by the two ITK translation units (itk_io.cpp, itk_filters.cpp) only: it
// includes ITK headers, so nothing else may include it (see itk_bridge.hpp).
#include <itkImage.h>
#include <itkMacro.h>

#include <algorithm>
#include <string>

#include "itk_bridge.hpp"

namespace voxpack::ingest::bridge {

/// An ITK exception's description on one line (the CLI prints one error line).
inline std::string itkMessage(const itk::ExceptionObject& e) {
  std::string d = e.GetDescription();
  for (char& c : d)
    if (c == '\n' || c == '\r') c = ' ';
  while (!d.empty() && d.back() == ' ') d.pop_back();
  return d;
}

/// Raw volume -> ITK image of pixel type T. `physical` = false puts it on unit spacing and
/// zero origin, so that ITK's diffusion time step is in voxel units whatever the spacing.
template <class T, class S>
typename itk::Image<T, 3>::Pointer toItk(const Raw<S>& r, bool physical) {
  using Image = itk::Image<T, 3>;
  auto img = Image::New();
  typename Image::SizeType size;
  typename Image::SpacingType sp;
  typename Image::PointType org;
  for (unsigned d = 0; d < 3; ++d) {
    size[d] = static_cast<itk::SizeValueType>(r.dims[2 - d]);
    sp[d] = physical ? r.spacing[2 - d] : 1.0;
    org[d] = physical ? r.origin[2 - d] : 0.0;
  }
  img->SetRegions(typename Image::RegionType(size));
  img->SetSpacing(sp);
  img->SetOrigin(org);
  img->Allocate();
  // ITK's buffer is x-fastest: exactly C order [z][y][x].
  std::transform(r.data.begin(), r.data.end(), img->GetBufferPointer(),
                 [](S v) { return static_cast<T>(v); });
  return img;
}

}  // namespace voxpack::ingest::bridge
