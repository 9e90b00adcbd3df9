// ITK-backed image reading and writing behind the plain bridge (itk_bridge.hpp). One of
// the two translation units of the module that include ITK (it compiles slowly).
#include <itkBMPImageIOFactory.h>
#include <itkBioRadImageIOFactory.h>
#include <itkBruker2dseqImageIOFactory.h>
#include <itkGDCMImageIO.h>
#include <itkGDCMImageIOFactory.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkGiplImageIOFactory.h>
#include <itkHDF5ImageIOFactory.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOFactory.h>
#include <itkImageSeriesReader.h>
#include <itkJPEGImageIOFactory.h>
#include <itkLSMImageIOFactory.h>
#include <itkMRCImageIOFactory.h>
#include <itkMetaDataObject.h>
#include <itkMetaImageIO.h>
#include <itkMetaImageIOFactory.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIO.h>
#include <itkNrrdImageIOFactory.h>
#include <itkObjectFactoryBase.h>
#include <itkPNGImageIOFactory.h>
#include <itkStimulateImageIOFactory.h>
#include <itkTIFFImageIOFactory.h>
#include <itkVTKImageIOFactory.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <mutex>

#include "itk_convert.hpp"
#include "text.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::ingest::bridge {
namespace {

using text::lower;

using FloatImage3 = itk::Image<float, 3>;
using FloatImage2 = itk::Image<float, 2>;

Raw<float> fromItk(const FloatImage3* img) {
  const auto size = img->GetLargestPossibleRegion().GetSize();
  const auto sp = img->GetSpacing();
  const auto org = img->GetOrigin();
  Raw<float> r;
  r.dims = {static_cast<std::int64_t>(size[2]), static_cast<std::int64_t>(size[1]),
            static_cast<std::int64_t>(size[0])};
  r.spacing = {sp[2], sp[1], sp[0]};
  r.origin = {org[2], org[1], org[0]};
  const std::size_t n = size[0] * size[1] * size[2];
  // ITK's buffer is x-fastest: exactly C order [z][y][x].
  r.data.assign(img->GetBufferPointer(), img->GetBufferPointer() + n);
  return r;
}

// ITK 5.2's MetaIO reads NDims numbers for each per-axis field (DimSize, ElementSpacing,
// Offset, ...) and trusts the count, though it keeps those values in arrays of 10
// (metaImage.h): a fuzzed 'NDims = 3111...1' kept its reader extracting from a spent stream
// for minutes (fuzz_image_header, timeout). Every reading path comes through createIO, so
// the count is checked here before ITK parses the header.
constexpr int kMetaMaxDims = 10;

void checkMetaImageDims(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(file + ": cannot open");
  // Every NDims line: MetaIO acts on each as it meets it, not on the last.
  for (const auto& f : text::metaImageFieldList(in)) {
    if (f.key != "ndims") continue;
    int dims = 0;
    const auto [end, ec] = std::from_chars(f.value.data(), f.value.data() + f.value.size(), dims);
    if (ec != std::errc() || end != f.value.data() + f.value.size() || dims < 1 ||
        dims > kMetaMaxDims)
      throw FormatError(file + ": NDims '" + f.value.substr(0, 40) +
                        "' is not a number of axes from 1 to " + std::to_string(kMetaMaxDims));
  }
}

itk::ImageIOBase::Pointer createIO(const std::string& file) {
  registerFactories();
  // NRRD and MetaImage files get their own reader: ITK's factory asks every reader whether
  // it can read the bytes, and an .mha beginning with the PNG signature (found by
  // fuzz_image_header) went to PNGImageIO, whose libpng error handler abort()s the process.
  const auto dot = file.find_last_of('.');
  const std::string ext = dot == std::string::npos ? "" : lower(file.substr(dot));
  itk::ImageIOBase::Pointer io;
  if (ext == ".nrrd" || ext == ".nhdr")
    io = itk::NrrdImageIO::New();
  else if (ext == ".mha" || ext == ".mhd")
    io = itk::MetaImageIO::New();
  if (io && !io->CanReadFile(file.c_str()))
    throw FormatError(file + ": not a " + (ext[1] == 'n' ? "NRRD" : "MetaImage") + " file");
  if (ext == ".mha" || ext == ".mhd") checkMetaImageDims(file);
  if (!io) io = itk::ImageIOFactory::CreateImageIO(file.c_str(), itk::IOFileModeEnum::ReadMode);
  if (!io) throw FormatError(file + ": not an image format ITK can read");
  io->SetFileName(file);
  try {
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw FormatError(file + ": cannot read the image header: " + itkMessage(e));
  }
  return io;
}

template <class T>
void writeTyped(const std::string& file, const Raw<float>& r,
                const std::map<std::string, std::string>& metadata) {
  using Image = itk::Image<T, 3>;
  auto img = toItk<T>(r, true);
  auto& dict = img->GetMetaDataDictionary();
  for (const auto& [k, v] : metadata) itk::EncapsulateMetaData<std::string>(dict, k, v);
  auto writer = itk::ImageFileWriter<Image>::New();
  writer->SetFileName(file);
  writer->SetInput(img);
  writer->SetUseCompression(true);
  writer->Update();
}

}  // namespace

std::vector<std::string> registerFactories() {
  // Without ITK_USE_FILE nothing registers the IO factories; doing it here keeps ITK's
  // global compile flags out of the build. Registration is process-wide, so once.
  static std::once_flag once;
  std::call_once(once, [] {
    itk::NrrdImageIOFactory::RegisterOneFactory();
    itk::MetaImageIOFactory::RegisterOneFactory();
    itk::NiftiImageIOFactory::RegisterOneFactory();
    itk::TIFFImageIOFactory::RegisterOneFactory();
    itk::GDCMImageIOFactory::RegisterOneFactory();
    itk::Bruker2dseqImageIOFactory::RegisterOneFactory();
    itk::VTKImageIOFactory::RegisterOneFactory();
    itk::PNGImageIOFactory::RegisterOneFactory();
    itk::BMPImageIOFactory::RegisterOneFactory();
    itk::JPEGImageIOFactory::RegisterOneFactory();
    itk::GiplImageIOFactory::RegisterOneFactory();
    itk::HDF5ImageIOFactory::RegisterOneFactory();
    itk::MRCImageIOFactory::RegisterOneFactory();
    itk::BioRadImageIOFactory::RegisterOneFactory();
    itk::LSMImageIOFactory::RegisterOneFactory();
    itk::StimulateImageIOFactory::RegisterOneFactory();
    // libtiff warns on every slice carrying ImageJ private tags; harmless, and it would
    // drown the CLI's one-line error contract.
    itk::Object::GlobalWarningDisplayOff();
  });
  std::vector<std::string> names;
  for (auto* f : itk::ObjectFactoryBase::GetRegisteredFactories())
    for (const auto& o : f->GetClassOverrideWithNames())
      if (lower(o).find("imageio") != std::string::npos)
        names.push_back(o.rfind("itk", 0) == 0 ? o.substr(3) : o);
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  return names;
}

Header readHeader(const std::string& file) {
  auto io = createIO(file);
  Header h;
  h.imageIO = io->GetNameOfClass();
  h.componentType = itk::ImageIOBase::GetComponentTypeAsString(io->GetComponentType());
  h.dimensions = io->GetNumberOfDimensions();
  for (unsigned d = 0; d < std::min(4u, h.dimensions); ++d) h.size[d] = io->GetDimensions(d);
  for (unsigned d = 0; d < std::min(3u, h.dimensions); ++d) {
    h.spacing[d] = io->GetSpacing(d);
    h.origin[d] = io->GetOrigin(d);
  }
  if (io->GetNumberOfComponents() > 1)
    h.metadata["voxpack_components"] = std::to_string(io->GetNumberOfComponents());
  const auto& dict = io->GetMetaDataDictionary();
  for (const auto& key : dict.GetKeys()) {
    std::string value;
    if (itk::ExposeMetaData<std::string>(dict, key, value) && value.size() < 512)
      h.metadata[key] = value;
  }
  return h;
}

Raw<float> readFile(const std::string& file) {
  auto io = createIO(file);
  auto reader = itk::ImageFileReader<FloatImage3>::New();
  reader->SetFileName(file);
  reader->SetImageIO(io);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw FormatError(file + ": cannot read the image data: " + itkMessage(e));
  }
  return fromItk(reader->GetOutput());
}

void readSlice(const std::string& file, float* dst, std::size_t count) {
  auto io = createIO(file);
  auto reader = itk::ImageFileReader<FloatImage2>::New();
  reader->SetFileName(file);
  reader->SetImageIO(io);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw FormatError(file + ": cannot read the slice: " + itkMessage(e));
  }
  const auto size = reader->GetOutput()->GetLargestPossibleRegion().GetSize();
  if (size[0] * size[1] != count) throw FormatError(file + ": slice size changed while reading");
  std::copy(reader->GetOutput()->GetBufferPointer(),
            reader->GetOutput()->GetBufferPointer() + count, dst);
}

bool isDicom(const std::string& file) {
  registerFactories();
  auto gdcm = itk::GDCMImageIO::New();
  return gdcm->CanReadFile(file.c_str());
}

Raw<float> readDicomSeries(const std::string& dir, std::vector<std::string>& files,
                           std::string& componentType, std::size_t& seriesCount) {
  registerFactories();
  auto names = itk::GDCMSeriesFileNames::New();
  names->SetUseSeriesDetails(true);
  names->SetDirectory(dir);
  const auto& uids = names->GetSeriesUIDs();
  if (uids.empty()) throw FormatError(dir + ": no DICOM series found");
  seriesCount = uids.size();
  files = names->GetFileNames(uids.front());
  if (files.size() < 2) throw FormatError(dir + ": the DICOM series holds one slice (a 2-D image)");
  auto gdcm = itk::GDCMImageIO::New();
  auto reader = itk::ImageSeriesReader<FloatImage3>::New();
  reader->SetImageIO(gdcm);
  reader->SetFileNames(files);
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw FormatError(dir + ": cannot read the DICOM series: " + itkMessage(e));
  }
  componentType = itk::ImageIOBase::GetComponentTypeAsString(gdcm->GetComponentType());
  return fromItk(reader->GetOutput());
}

bool canWrite(const std::string& file) {
  registerFactories();
  return static_cast<bool>(
      itk::ImageIOFactory::CreateImageIO(file.c_str(), itk::IOFileModeEnum::WriteMode));
}

void write(const std::string& file, const Raw<float>& image, int pixelType,
           const std::map<std::string, std::string>& metadata) {
  registerFactories();
  try {
    switch (pixelType) {
      case 0:
        writeTyped<std::uint8_t>(file, image, metadata);
        break;
      case 1:
        writeTyped<std::uint16_t>(file, image, metadata);
        break;
      default:
        writeTyped<float>(file, image, metadata);
        break;
    }
  } catch (const itk::ExceptionObject& e) {
    throw IoError(file + ": cannot write: " + itkMessage(e));
  }
}

void writeDicomSeries(const std::string& dir, const Raw<float>& image) {
  registerFactories();
  using Slice = itk::Image<std::int16_t, 3>;
  // Fixed UIDs under a test root: every slice must carry the same study and series UID
  // or the series reader splits them; KeepOriginalUID makes GDCM use ours.
  const std::string root = "1.2.826.0.1.3680043.2.1125.77";
  const std::string study = root + ".1", series = root + ".2";
  const auto nx = static_cast<std::size_t>(image.dims[2]),
             ny = static_cast<std::size_t>(image.dims[1]);
  for (std::int64_t k = 0; k < image.dims[0]; ++k) {
    auto img = Slice::New();
    Slice::SizeType size;
    size[0] = nx;
    size[1] = ny;
    size[2] = 1;
    img->SetRegions(Slice::RegionType(size));
    Slice::SpacingType sp;
    Slice::PointType org;
    sp[0] = image.spacing[2];
    sp[1] = image.spacing[1];
    sp[2] = image.spacing[0];
    org[0] = image.origin[2];
    org[1] = image.origin[1];
    org[2] = image.origin[0] + static_cast<double>(k) * image.spacing[0];
    img->SetSpacing(sp);
    img->SetOrigin(org);
    img->Allocate();
    const float* src = image.data.data() + static_cast<std::size_t>(k) * nx * ny;
    std::transform(src, src + nx * ny, img->GetBufferPointer(),
                   [](float v) { return static_cast<std::int16_t>(v); });
    auto& dict = img->GetMetaDataDictionary();
    itk::EncapsulateMetaData<std::string>(dict, "0008|0060", "MR");
    itk::EncapsulateMetaData<std::string>(dict, "0020|000d", study);
    itk::EncapsulateMetaData<std::string>(dict, "0020|000e", series);
    itk::EncapsulateMetaData<std::string>(dict, "0008|0018", series + "." + std::to_string(k + 1));
    itk::EncapsulateMetaData<std::string>(dict, "0020|0013", std::to_string(k + 1));
    auto io = itk::GDCMImageIO::New();
    io->KeepOriginalUIDOn();
    auto writer = itk::ImageFileWriter<Slice>::New();
    char name[32];
    std::snprintf(name, sizeof name, "/img%04lld.dcm", static_cast<long long>(k));
    writer->SetFileName(dir + name);
    writer->SetImageIO(io);
    writer->SetInput(img);
    try {
      writer->Update();
    } catch (const itk::ExceptionObject& e) {
      throw IoError(dir + name + ": cannot write: " + itkMessage(e));
    }
  }
}

}  // namespace voxpack::ingest::bridge
