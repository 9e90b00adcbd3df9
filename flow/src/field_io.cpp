// --field (HDF5 bed file + velocity and pressure, XDMF beside it) and --csv output.
#include <hdf5.h>

#include <fstream>
#include <sstream>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/bed_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/flow/flow.hpp"

namespace voxpack::flow {
namespace {

void writeFloatDataset(hid_t file, const char* name, int rank, const hsize_t* dims,
                       const std::vector<float>& data) {
  const hid_t space = H5Screate_simple(rank, dims, nullptr);
  const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
  hsize_t chunk[4];
  for (int r = 0; r < rank; ++r) chunk[r] = std::min<hsize_t>(dims[r], r == 0 ? 8 : 128);
  H5Pset_chunk(plist, rank, chunk);
  H5Pset_deflate(plist, 4);
  const hid_t ds = H5Dcreate2(file, name, H5T_IEEE_F32LE, space, H5P_DEFAULT, plist, H5P_DEFAULT);
  herr_t st =
      ds < 0 ? -1 : H5Dwrite(ds, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
  if (ds >= 0) H5Dclose(ds);
  H5Pclose(plist);
  H5Sclose(space);
  if (st < 0) throw IoError(std::string("--field: cannot write dataset ") + name);
}

}  // namespace

void writeFlowField(const std::filesystem::path& path, const Bed& bed, const FlowReport& rep) {
  const Lattice& lat = bed.lattice();
  const auto sd = lat.dims;
  const std::size_t n = lat.size();
  std::vector<float> vel(3 * n, 0.0f), pres(n, 0.0f);
  const auto dd = rep.domain.dims;
  const LbmResult& r = rep.lbm;
  const int a = rep.json.value("axis", std::string("z")) == "z"   ? 0
                : rep.json.value("axis", std::string("z")) == "y" ? 1
                                                                  : 2;
  const double force = rep.json["lattice"].value("force", 0.0);
  const std::int64_t len = sd[static_cast<std::size_t>(a)];
  std::int64_t trimLo = 0, trimHi = 0;
  if (rep.json.contains("trimmed_layers") && rep.json["trimmed_layers"].is_array()) {
    trimLo = rep.json["trimmed_layers"][0].get<std::int64_t>();
    trimHi = rep.json["trimmed_layers"][1].get<std::int64_t>();
  }
  for (std::size_t c = 0; c < r.fluidCells; ++c) {
    const std::uint64_t off = r.cellOffset[c];
    std::int64_t p[3] = {static_cast<std::int64_t>(off) / (dd[1] * dd[2]),
                         (static_cast<std::int64_t>(off) / dd[2]) % dd[1],
                         static_cast<std::int64_t>(off) % dd[2]};
    p[a] -= rep.sampleStart;
    if (p[a] < 0 || p[a] >= len - trimLo - trimHi) continue;
    if (a == 0) p[0] += trimLo;  // computeFlow dropped end layers outside the mask
    const std::size_t so = lat.offset(p[0], p[1], p[2]);
    // (x, y, z) components for ParaView; the lattice stores (z, y, x).
    for (int d = 0; d < 3; ++d)
      vel[3 * so + static_cast<std::size_t>(d)] =
          static_cast<float>(r.fields.velocity[2 - d][c] * rep.velocityScale);
    // Reduced pressure: the lattice pressure minus the work of the body force, which
    // stands for the mean pressure gradient of the real column.
    const double pl = r.fields.density[c] / 3.0 - force * static_cast<double>(p[a]);
    pres[so] = static_cast<float>(pl * rep.pressureScale);
  }
  AtomicOutput out(path);
  writeBed(out.tempPath(), bed);
  {
    const hid_t file = H5Fopen(out.tempPath().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (file < 0) throw IoError("--field: cannot reopen " + out.tempPath().string());
    const hsize_t d4[4] = {static_cast<hsize_t>(sd[0]), static_cast<hsize_t>(sd[1]),
                           static_cast<hsize_t>(sd[2]), 3};
    try {
      writeFloatDataset(file, "/velocity", 4, d4, vel);
      writeFloatDataset(file, "/pressure", 3, d4, pres);
    } catch (...) {
      H5Fclose(file);
      throw;
    }
    H5Fclose(file);
  }
  out.commit();
  // XDMF: a 3D co-rectilinear mesh over the voxel centres (ParaView, VisIt).
  std::filesystem::path xdmf = path;
  xdmf.replace_extension(".xdmf");
  const std::string h5 = path.filename().string();
  std::ostringstream x;
  const std::string dims =
      std::to_string(sd[0]) + " " + std::to_string(sd[1]) + " " + std::to_string(sd[2]);
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n  <Grid Name=\"flow\">\n"
    << "   <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << dims << "\"/>\n"
    << "   <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
    << "    <DataItem Dimensions=\"3\" Format=\"XML\">" << lat.originMm[0] << " " << lat.originMm[1]
    << " " << lat.originMm[2] << "</DataItem>\n"
    << "    <DataItem Dimensions=\"3\" Format=\"XML\">" << lat.spacingMm[0] << " "
    << lat.spacingMm[1] << " " << lat.spacingMm[2] << "</DataItem>\n   </Geometry>\n"
    << "   <Attribute Name=\"indicator\" Center=\"Node\"><DataItem Dimensions=\"" << dims
    << "\" NumberType=\"UChar\" Format=\"HDF\">" << h5 << ":/indicator</DataItem></Attribute>\n"
    << "   <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\"><DataItem "
       "Dimensions=\""
    << dims << " 3\" NumberType=\"Float\" Precision=\"4\" Format=\"HDF\">" << h5
    << ":/velocity</DataItem></Attribute>\n"
    << "   <Attribute Name=\"pressure\" Center=\"Node\"><DataItem Dimensions=\"" << dims
    << "\" NumberType=\"Float\" Precision=\"4\" Format=\"HDF\">" << h5
    << ":/pressure</DataItem></Attribute>\n  </Grid>\n </Domain>\n</Xdmf>\n";
  writeTextFileAtomic(xdmf, x.str());
}

void writeFlowCsv(const nlohmann::json& flow, const std::filesystem::path& dir) {
  ensureWritableDirectory(dir, true);
  std::ostringstream rp;
  rp << "wall_distance_mm,axial_velocity_over_superficial,porosity\n";
  if (flow.contains("radial_profile") && flow["radial_profile"].is_object()) {
    const auto& p = flow["radial_profile"];
    for (std::size_t b = 0; b < p["wall_distance_mm"].size(); ++b)
      rp << p["wall_distance_mm"][b] << ',' << p["axial_velocity_over_superficial"][b] << ','
         << p["porosity"][b] << '\n';
  }
  writeTextFileAtomic(dir / "radial_profile.csv", rp.str());
  std::ostringstream ch;
  ch << "step,mean_axial_velocity_lattice\n";
  if (flow.contains("convergence_history"))
    for (const auto& e : flow["convergence_history"]) ch << e[0] << ',' << e[1] << '\n';
  writeTextFileAtomic(dir / "convergence.csv", ch.str());
}

}  // namespace voxpack::flow
