// Format names, default output paths and the NRRD/MetaImage writer (ITK lives in ingest/).
#include "voxpack/export/formats.hpp"

#include "voxpack/core/errors.hpp"
#include "voxpack/ingest/image_writer.hpp"

namespace voxpack::exporter {

namespace fs = std::filesystem;

Format parseFormat(const std::string& name) {
  if (name == "stl") return Format::Stl;
  if (name == "obj") return Format::Obj;
  if (name == "xdmf") return Format::Xdmf;
  if (name == "vtkhdf") return Format::VtkHdf;
  if (name == "vtk") return Format::Vtk;
  if (name == "tiff" || name == "tif") return Format::Tiff;
  if (name == "nrrd") return Format::Nrrd;
  if (name == "mha") return Format::Mha;
  if (name == "csv") return Format::Csv;
  throw UsageError("--format: unknown format '" + name +
                   "' (expected stl, obj, xdmf, vtkhdf, vtk, tiff, nrrd, mha, csv)");
}

fs::path defaultOutput(const fs::path& bedPath, Format format) {
  fs::path out = bedPath;
  switch (format) {
    case Format::Stl:
      return out.replace_extension(".stl");
    case Format::Obj:
      return out.replace_extension(".obj");
    case Format::Xdmf:
      return out.replace_extension(".xdmf");
    case Format::VtkHdf:
      return out.replace_extension(".vtkhdf");
    case Format::Vtk:
      return out.replace_extension(".vtk");
    case Format::Tiff:
      return out.replace_extension("").string() + "_tiff";
    case Format::Nrrd:
      return out.replace_extension(".nrrd");
    case Format::Mha:
      return out.replace_extension(".mha");
    case Format::Csv:
      return out.replace_extension(".csv");
  }
  return out;
}

void writeIndicatorImage(const Grid<std::uint8_t>& indicator, const fs::path& out) {
  ingest::writeImageUint8(indicator, out);
}

}  // namespace voxpack::exporter
