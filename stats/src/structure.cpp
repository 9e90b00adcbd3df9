// Pore sizes (EDT), chord lengths, shadow images, coordination, orientations (docs/stats.md).
#include "voxpack/stats/structure.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <unordered_set>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::stats {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool voidAt(const Bed& bed, std::size_t o) {
  return bed.indicator[o] != 0 && (!bed.mask || (*bed.mask)[o] != 0);
}

// 1D squared distance transform of samples f (spacing h) into d: lower envelope of the
// parabolas rooted at the finite samples (Felzenszwalb & Huttenlocher 2012).
void distance1d(const double* f, std::int64_t n, double h, double* d, std::vector<std::int64_t>& v,
                std::vector<double>& z) {
  v.resize(static_cast<std::size_t>(n));
  z.resize(static_cast<std::size_t>(n) + 1);
  std::int64_t k = -1;
  for (std::int64_t q = 0; q < n; ++q) {
    if (!std::isfinite(f[q])) continue;
    const double pq = static_cast<double>(q) * h;
    while (k >= 0) {
      const std::int64_t r = v[static_cast<std::size_t>(k)];
      const double pr = static_cast<double>(r) * h;
      const double s = ((f[q] + pq * pq) - (f[r] + pr * pr)) / (2 * (pq - pr));
      if (s <= z[static_cast<std::size_t>(k)]) {
        --k;
      } else {
        ++k;
        v[static_cast<std::size_t>(k)] = q;
        z[static_cast<std::size_t>(k)] = s;
        z[static_cast<std::size_t>(k) + 1] = kInf;
        break;
      }
    }
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
    }
  }
  if (k < 0) {
    for (std::int64_t p = 0; p < n; ++p) d[p] = kInf;
    return;
  }
  std::int64_t j = 0;
  for (std::int64_t p = 0; p < n; ++p) {
    const double pp = static_cast<double>(p) * h;
    while (z[static_cast<std::size_t>(j) + 1] < pp) ++j;
    const std::int64_t r = v[static_cast<std::size_t>(j)];
    const double dr = pp - static_cast<double>(r) * h;
    d[p] = dr * dr + f[r];
  }
}

}  // namespace

std::vector<double> squaredDistanceTransform(const std::vector<std::uint8_t>& source,
                                             const Lattice& l, int threads) {
  const std::int64_t n[3] = {l.nz(), l.ny(), l.nx()};
  std::vector<double> g(source.size());
  for (std::size_t o = 0; o < source.size(); ++o) g[o] = source[o] ? 0.0 : kInf;
  // One pass per axis a over every line along a; strides in C order.
  const std::int64_t stride[3] = {n[1] * n[2], n[2], 1};
  for (int a = 2; a >= 0; --a) {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    const std::int64_t lines = n[u] * n[w];
#pragma omp parallel num_threads(std::max(1, threads))
    {
      std::vector<double> in(static_cast<std::size_t>(n[a])), out(static_cast<std::size_t>(n[a]));
      std::vector<std::int64_t> v;
      std::vector<double> z;
#pragma omp for schedule(static)
      for (std::int64_t line = 0; line < lines; ++line) {
        const std::int64_t iu = line / n[w], iw = line % n[w];
        const std::int64_t base = iu * stride[u] + iw * stride[w];
        for (std::int64_t t = 0; t < n[a]; ++t)
          in[static_cast<std::size_t>(t)] = g[static_cast<std::size_t>(base + t * stride[a])];
        distance1d(in.data(), n[a], l.spacingMm[a], out.data(), v, z);
        for (std::int64_t t = 0; t < n[a]; ++t)
          g[static_cast<std::size_t>(base + t * stride[a])] = out[static_cast<std::size_t>(t)];
      }
    }
  }
  return g;
}

PoreSizeDistribution poreSizeDistribution(const Bed& bed, double binWidthMm, int threads) {
  const Lattice& l = bed.lattice();
  std::vector<std::uint8_t> source(l.size());
  for (std::size_t o = 0; o < l.size(); ++o) source[o] = !voidAt(bed, o);
  const std::vector<double> d2 = squaredDistanceTransform(source, l, threads);
  std::vector<double> values;
  PoreSizeDistribution p;
  for (std::size_t o = 0; o < l.size(); ++o)
    if (!source[o] && std::isfinite(d2[o])) {
      values.push_back(std::sqrt(d2[o]));
      p.maxMm = std::max(p.maxMm, values.back());
    }
  const double width =
      binWidthMm > 0 ? binWidthMm : std::min({l.spacingMm[0], l.spacingMm[1], l.spacingMm[2]}) / 2;
  p.distribution = summarizeLengths(values, width);
  const auto& pdf = p.distribution.pdf;
  double above = 1;
  for (std::size_t b = 0; b < pdf.size(); ++b) {
    p.ccdfMm.push_back(static_cast<double>(b) * width);
    p.ccdf.push_back(std::max(0.0, above));
    above -= pdf[b] * width;
  }
  return p;
}

ShadowImage shadowImage(const Bed& bed, int axis) {
  if (axis < 0 || axis > 2) throw InputError("shadow image: axis must be 0, 1 or 2");
  const Lattice& l = bed.lattice();
  const std::int64_t n[3] = {l.nz(), l.ny(), l.nx()};
  ShadowImage img;
  const int r = axis == 0 ? 1 : 0, c = axis == 2 ? 1 : 2;
  img.rows = n[r];
  img.cols = n[c];
  std::vector<double> solid(static_cast<std::size_t>(img.rows * img.cols), 0.0),
      count(solid.size(), 0.0);
  for (std::int64_t k = 0; k < n[0]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[2]; ++i) {
        const std::size_t o = l.offset(k, j, i);
        if (bed.mask && (*bed.mask)[o] == 0) continue;
        const std::int64_t idx[3] = {k, j, i};
        const auto p = static_cast<std::size_t>(idx[r] * img.cols + idx[c]);
        count[p] += 1;
        solid[p] += bed.indicator[o] == 0;
      }
  img.values.resize(solid.size());
  for (std::size_t p = 0; p < solid.size(); ++p)
    img.values[p] = count[p] > 0 ? solid[p] / count[p] : kNaN;
  return img;
}

Coordination coordinationNumbers(const Bed& bed) {
  if (!bed.labels) throw InputError("coordination numbers need particle labels (/labels)");
  const Lattice& l = bed.lattice();
  const auto& lab = *bed.labels;
  std::unordered_set<std::uint64_t> pairs;
  std::uint32_t maxLabel = 0;
  const std::int64_t nz = l.nz(), ny = l.ny(), nx = l.nx();
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const std::uint32_t a = lab(k, j, i);
        if (a == 0) continue;
        maxLabel = std::max(maxLabel, a);
        const std::uint32_t nb[3] = {k + 1 < nz ? lab(k + 1, j, i) : 0u,
                                     j + 1 < ny ? lab(k, j + 1, i) : 0u,
                                     i + 1 < nx ? lab(k, j, i + 1) : 0u};
        for (std::uint32_t b : nb)
          if (b != 0 && b != a) {
            const std::uint64_t lo = std::min(a, b), hi = std::max(a, b);
            pairs.insert(lo << 32 | hi);
          }
      }
  // Per-label tables are indexed by the labels present (sorted), never by the label value:
  // one voxel labelled 0xFFFFFFFF must not ask for a 2^32-entry table (docs/stats.md).
  (void)maxLabel;
  std::vector<std::uint32_t> present;
  {
    std::unordered_set<std::uint32_t> seen;
    for (std::size_t o = 0; o < lab.size(); ++o)
      if (lab[o] != 0 && seen.insert(lab[o]).second) present.push_back(lab[o]);
  }
  std::sort(present.begin(), present.end());
  auto slot = [&](std::uint32_t label) {
    return static_cast<std::size_t>(std::lower_bound(present.begin(), present.end(), label) -
                                    present.begin());
  };
  std::vector<double> perLabel(present.size(), 0.0);
  for (std::uint64_t p : pairs) {
    perLabel[slot(static_cast<std::uint32_t>(p >> 32))] += 1;
    perLabel[slot(static_cast<std::uint32_t>(p & 0xffffffffu))] += 1;
  }
  Coordination c;
  c.contacts = pairs.size();
  double sum = 0;
  for (double v : perLabel) {
    c.perParticle.push_back(v);
    sum += v;
  }
  c.particles = c.perParticle.size();
  c.mean = c.particles ? sum / static_cast<double>(c.particles) : kNaN;
  return c;
}

OrientationDistribution orientationDistribution(const Bed& bed, int bins) {
  if (bed.particles.orientation.empty())
    throw InputError("orientation distribution needs particle orientations");
  if (bins < 1) throw InputError("orientation distribution: bins must be >= 1");
  OrientationDistribution d;
  double cosSum = 0, orderSum = 0;
  for (const Quat& q : bed.particles.orientation) {
    const Vec3 axis = q.normalized() * Vec3::UnitZ();
    const double c = std::min(1.0, std::abs(axis.z()));
    d.anglesDeg.push_back(std::acos(c) * 180 / std::numbers::pi);
    cosSum += c;
    orderSum += 0.5 * (3 * c * c - 1);
  }
  const double n = static_cast<double>(d.anglesDeg.size());
  d.meanCos = cosSum / n;
  d.orderParameter = orderSum / n;
  d.histogram.assign(static_cast<std::size_t>(bins), 0.0);
  for (int b = 0; b <= bins; ++b) d.histogramEdgesDeg.push_back(90.0 * b / bins);
  for (double a : d.anglesDeg)
    d.histogram[std::min(static_cast<std::size_t>(bins) - 1,
                         static_cast<std::size_t>(a / 90.0 * bins))] += 1 / n;
  return d;
}

namespace {
std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0) {
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}
void put32(std::string& s, std::uint32_t v) {
  for (int b = 3; b >= 0; --b) s.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
}
void chunk(std::string& png, const char* type, const std::string& data) {
  put32(png, static_cast<std::uint32_t>(data.size()));
  std::string body(type, 4);
  body += data;
  png += body;
  put32(png, crc32(reinterpret_cast<const std::uint8_t*>(body.data()), body.size()));
}
}  // namespace

void writeGreyPng(const ShadowImage& img, const std::string& path, bool flipRows) {
  if (img.rows < 1 || img.cols < 1) throw InputError("PNG: empty image");
  // Raw scanlines (filter byte 0), stored in uncompressed deflate blocks: no zlib needed.
  std::string raw;
  for (std::int64_t r = 0; r < img.rows; ++r) {
    const std::int64_t src = flipRows ? img.rows - 1 - r : r;
    raw.push_back(0);
    for (std::int64_t c = 0; c < img.cols; ++c) {
      const double v = img.values[static_cast<std::size_t>(src * img.cols + c)];
      const double g = std::isfinite(v) ? 255.0 * (1.0 - std::clamp(v, 0.0, 1.0)) : 255.0;
      raw.push_back(static_cast<char>(static_cast<std::uint8_t>(std::lround(g))));
    }
  }
  std::string z{"\x78\x01", 2};
  std::size_t pos = 0;
  do {
    const std::size_t len = std::min<std::size_t>(65535, raw.size() - pos);
    const bool last = pos + len == raw.size();
    z.push_back(last ? 1 : 0);
    z.push_back(static_cast<char>(len & 0xff));
    z.push_back(static_cast<char>(len >> 8));
    z.push_back(static_cast<char>(~len & 0xff));
    z.push_back(static_cast<char>((~len >> 8) & 0xff));
    z.append(raw, pos, len);
    pos += len;
  } while (pos < raw.size());
  std::uint32_t a = 1, b = 0;
  for (unsigned char ch : raw) {
    a = (a + ch) % 65521;
    b = (b + a) % 65521;
  }
  put32(z, (b << 16) | a);
  std::string png{"\x89PNG\r\n\x1a\n", 8};
  std::string ihdr;
  put32(ihdr, static_cast<std::uint32_t>(img.cols));
  put32(ihdr, static_cast<std::uint32_t>(img.rows));
  ihdr += std::string{"\x08\x00\x00\x00\x00", 5};  // 8-bit grey, no interlace
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", "");
  AtomicOutput out(path);
  {
    std::ofstream f(out.tempPath(), std::ios::binary);
    f.write(png.data(), static_cast<std::streamsize>(png.size()));
    if (!f) throw IoError("cannot write " + path);
  }
  out.commit();
}

}  // namespace voxpack::stats
