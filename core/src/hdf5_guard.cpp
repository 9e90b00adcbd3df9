// Object header and chunk checks ahead of libhdf5 (see hdf5_guard.hpp). The layouts parsed
// here are those of the HDF5 file format specification 3.0 (docs/references.md, "File formats"):
// object header versions 1 and 2, attribute message versions 1-3, dataspace versions 1-2.
#include "hdf5_guard.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <set>
#include <vector>

#include "hdf5_raw.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::hdf5guard {

namespace {

using detail::Id;
using detail::le;
using detail::RawFile;

std::uint64_t align8(std::uint64_t n) { return (n + 7) / 8 * 8; }

constexpr unsigned kMsgContinuation = 0x10;
constexpr unsigned kMsgAttribute = 0x0C;
constexpr unsigned kMsgFlagShared = 0x02;

// Checks an attribute's datatype message (`n` bytes) and returns the size of one element as
// stored in the message. Only the classes voxpack writes are read: fixed-point and floating
// point numbers of 1 to 8 bytes, fixed-length strings and variable-length strings. libhdf5
// 1.10 decodes an enum's member names with strdup up to a NUL the message may not hold, and
// it copies an attribute's data by the declared size but later reads a variable-length
// element as 4 + address size + 4 bytes (H5T_set_loc), and allocates (and zeroes) a
// string's length times its declared character size: a 13.5 KB bed whose character was
// 1.8 GB wide took 19 GB and two minutes to be refused.
std::uint64_t checkDatatype(const RawFile& raw, const unsigned char* t, std::uint64_t n,
                            const std::string& where) {
  constexpr unsigned kFixed = 0, kFloat = 1, kString = 3, kVlen = 9;
  const unsigned cls = t[0] & 0x0F;
  const std::uint64_t size = le(t + 4, 4);
  switch (cls) {
    case kFixed:
    case kFloat:
      if (size != 1 && size != 2 && size != 4 && size != 8)
        raw.fail(where + ": a number of " + std::to_string(size) + " bytes");
      return size;
    case kString:
      return size;
    case kVlen: {
      // Class bits 0-3: 1 = string (a sequence is not written by voxpack); the base type,
      // a full datatype message of one character, follows the 8-byte head.
      if ((t[1] & 0x0F) != 1) raw.fail(where + ": a variable-length sequence");
      if (n < 16) raw.fail(where + ": variable-length string datatype truncated");
      const unsigned baseCls = t[8] & 0x0F;
      const std::uint64_t baseSize = le(t + 12, 4);
      if ((baseCls != kFixed && baseCls != kString) || baseSize != 1)
        raw.fail(where + ": a variable-length string of " + std::to_string(baseSize) +
                 "-byte characters");
      // libhdf5 copies `size` bytes of data and then reads 4 + address size + 4.
      const std::uint64_t stored = 4 + raw.sizeofAddr() + 4;
      if (size != stored)
        raw.fail(where + ": a variable-length string element of " + std::to_string(size) +
                 " bytes, not " + std::to_string(stored));
      return stored;
    }
    default:
      raw.fail(where + ": datatype class " + std::to_string(cls) + ", which voxpack does not read");
  }
}

// Checks one attribute message: H5O__attr_decode copies (element size x points) bytes of
// data out of the message without comparing them with the message's size.
void checkAttribute(const RawFile& raw, const unsigned char* d, std::uint64_t size,
                    unsigned msgFlags, const std::string& what) {
  const std::string where = what + ": attribute message";
  if (msgFlags & kMsgFlagShared) raw.fail(where + " is shared, which voxpack does not read");
  if (size < 8) raw.fail(where + " of " + std::to_string(size) + " bytes is truncated");
  const unsigned version = d[0];
  if (version < 1 || version > 3) raw.fail(where + " has version " + std::to_string(version));
  if (version > 1 && (d[1] & 0x03))
    raw.fail(where + " has a shared datatype or dataspace, which voxpack does not read");
  const std::uint64_t nameLen = le(d + 2, 2), dtLen = le(d + 4, 2), dsLen = le(d + 6, 2);
  const std::uint64_t head = version == 3 ? 9 : 8;
  auto pad = [&](std::uint64_t n) { return version == 1 ? align8(n) : n; };
  const std::uint64_t dtAt = head + pad(nameLen), dsAt = dtAt + pad(dtLen),
                      dataAt = dsAt + pad(dsLen);
  if (dataAt > size || dtLen < 8 || dsLen < 2)
    raw.fail(where + " declares a name, datatype and dataspace larger than the message (" +
             std::to_string(dataAt) + " of " + std::to_string(size) + " bytes)");
  const std::uint64_t element = checkDatatype(raw, d + dtAt, dtLen, where);

  const unsigned char* s = d + dsAt;
  const unsigned dsVersion = s[0], rank = s[1];
  std::uint64_t dimsAt = 0;
  bool null = false;
  if (dsVersion == 1) {
    dimsAt = 8;
  } else if (dsVersion == 2) {
    dimsAt = 4;
    if (dsLen < 4) raw.fail(where + ": dataspace truncated");
    null = s[3] == 2;
  } else {
    raw.fail(where + ": dataspace version " + std::to_string(dsVersion));
  }
  if (rank > 32 || dimsAt + rank * raw.sizeofSize() > dsLen)
    raw.fail(where + ": dataspace of rank " + std::to_string(rank) + " does not fit its " +
             std::to_string(dsLen) + " bytes");
  std::uint64_t points = null ? 0 : 1;
  for (unsigned r = 0; r < rank && points > 0; ++r) {
    const std::uint64_t dim = le(s + dimsAt + r * raw.sizeofSize(), raw.sizeofSize());
    if (dim != 0 && points > size / dim)
      points = size + 1;  // already more than can fit
    else
      points *= dim;
  }
  const std::uint64_t avail = size - dataAt;
  if (points > 0 && (element == 0 || element > avail || points > avail / element))
    raw.fail(where + " declares " + std::to_string(points) + " values of " +
             std::to_string(element) + " bytes, more than the " + std::to_string(avail) +
             " bytes it holds");
}

// Walks the messages of one object header block, queueing continuation blocks.
struct Walker {
  RawFile& raw;
  const std::string& what;
  bool v2 = false;
  bool creationOrder = false;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> pending;  // continuation (address, length)

  void messages(const unsigned char* p, std::uint64_t n) {
    const std::uint64_t head = v2 ? (creationOrder ? 6 : 4) : 8;
    std::uint64_t at = 0;
    while (n - at >= head) {
      const unsigned char* m = p + at;
      const unsigned type = v2 ? m[0] : static_cast<unsigned>(le(m, 2));
      const std::uint64_t size = v2 ? le(m + 1, 2) : le(m + 2, 2);
      const unsigned flags = v2 ? m[3] : m[4];
      if (size > n - at - head)
        raw.fail(what + ": object header message of " + std::to_string(size) +
                 " bytes overruns its block");
      const unsigned char* data = m + head;
      if (type == kMsgAttribute) checkAttribute(raw, data, size, flags, what);
      if (type == kMsgContinuation) {
        const std::size_t a = raw.sizeofAddr(), l = raw.sizeofSize();
        if (size < a + l) raw.fail(what + ": continuation message truncated");
        pending.emplace_back(le(data, a), le(data + a, l));
      }
      at += head + size;
    }
  }
};

}  // namespace

void checkAttributeMessages(hid_t obj, const std::string& file, const std::string& what) {
  H5O_info_t info;
  if (H5Oget_info2(obj, &info, H5O_INFO_BASIC) < 0)
    throw FormatError(file + ": cannot locate the object header of " + what);
  RawFile raw(obj, file);
  Walker w{raw, what, false, false, {}};
  // Bounds on the walk: libhdf5's own header loader limits a block to 64 KiB + overhead in
  // v1 and to the length field in v2; 1024 blocks is far beyond what any writer produces.
  constexpr std::uint64_t kMaxBlock = std::uint64_t{16} << 20;
  constexpr std::size_t kMaxBlocks = 1024;

  if (info.addr >= raw.size()) raw.fail(what + ": object header lies outside the file");
  const auto prefix =
      raw.read(info.addr, std::min<std::uint64_t>(32, raw.size() - info.addr), what + " header");
  if (prefix.size() >= 8 && std::memcmp(prefix.data(), "OHDR", 4) == 0) {
    w.v2 = true;
    const unsigned flags = prefix[5];
    if (prefix[4] != 2) raw.fail(what + ": object header version " + std::to_string(prefix[4]));
    w.creationOrder = flags & 0x04;
    std::uint64_t at = 6 + ((flags & 0x20) ? 16 : 0) + ((flags & 0x10) ? 4 : 0);
    const std::size_t lenBytes = std::size_t{1} << (flags & 0x03);
    if (at + lenBytes > prefix.size()) raw.fail(what + ": object header truncated");
    const std::uint64_t chunk0 = le(prefix.data() + at, lenBytes);
    at += lenBytes;
    if (chunk0 > kMaxBlock) raw.fail(what + ": object header block too large");
    const auto block = raw.read(info.addr + at, chunk0, what + " header");
    w.messages(block.data(), block.size());
  } else {
    if (prefix.size() < 16 || prefix[0] != 1)
      raw.fail(what + ": object header version " + std::to_string(prefix.empty() ? 0 : prefix[0]));
    const std::uint64_t size = le(prefix.data() + 8, 4);
    if (size > kMaxBlock) raw.fail(what + ": object header block too large");
    const auto block = raw.read(info.addr + 16, size, what + " header");
    w.messages(block.data(), block.size());
  }
  std::set<std::uint64_t> seen;
  while (!w.pending.empty()) {
    const auto [addr, len] = w.pending.back();
    w.pending.pop_back();
    if (!seen.insert(addr).second) raw.fail(what + ": object header continuation loops");
    if (seen.size() > kMaxBlocks || len > kMaxBlock)
      raw.fail(what + ": object header continuation too large");
    const auto block = raw.read(addr, len, what + " header continuation");
    if (w.v2) {
      if (block.size() < 8 || std::memcmp(block.data(), "OCHK", 4) != 0)
        raw.fail(what + ": object header continuation has no signature");
      w.messages(block.data() + 4, block.size() - 8);
    } else {
      w.messages(block.data(), block.size());
    }
  }
}

namespace {

// Inflates a zlib stream into exactly `out.size()` bytes; false when it holds fewer or more.
bool inflateExact(const std::vector<unsigned char>& in, std::vector<unsigned char>& out) {
  z_stream z{};
  if (inflateInit(&z) != Z_OK) return false;
  z.next_in = const_cast<Bytef*>(in.data());
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = inflate(&z, Z_FINISH);
  const bool exact = rc == Z_STREAM_END && z.total_out == out.size();
  inflateEnd(&z);
  return exact;
}

// Undoes the shuffle filter: byte b of element e was stored at b * count + e.
void unshuffle(std::vector<unsigned char>& buf, std::size_t element) {
  if (element <= 1) return;
  const std::size_t count = buf.size() / element;
  std::vector<unsigned char> out(buf.size());
  for (std::size_t b = 0; b < element; ++b)
    for (std::size_t e = 0; e < count; ++e) out[e * element + b] = buf[b * count + e];
  std::copy(buf.begin() + static_cast<std::ptrdiff_t>(count * element), buf.end(),
            out.begin() + static_cast<std::ptrdiff_t>(count * element));
  buf.swap(out);
}

}  // namespace

bool readChunksChecked(hid_t ds, hid_t memType, int rank, const hsize_t* start,
                       const hsize_t* count, void* out, bool mpio, const std::string& file,
                       const std::string& what) {
  if (rank < 1 || rank > 3) return false;
  Id dcpl{H5Dget_create_plist(ds), H5Pclose};
  if (!dcpl.ok() || H5Pget_layout(dcpl.id) != H5D_CHUNKED) return false;
  Id ftype{H5Dget_type(ds), H5Tclose};
  if (!ftype.ok() || H5Tequal(ftype.id, memType) <= 0) return false;
  // H5Dread_chunk does not work through MPI-IO, and asking a file for its driver there is a
  // collective call; the ranks read by H5Dread.
  if (mpio) return false;
  const int nFilters = H5Pget_nfilters(dcpl.id);
  if (nFilters < 0 || nFilters > 2) return false;
  std::vector<H5Z_filter_t> filters;
  for (int i = 0; i < nFilters; ++i) {
    unsigned flags = 0, config = 0;
    size_t nValues = 8;
    unsigned values[8];
    char name[64];
    const H5Z_filter_t id = H5Pget_filter2(dcpl.id, static_cast<unsigned>(i), &flags, &nValues,
                                           values, sizeof name, name, &config);
    if (id != H5Z_FILTER_DEFLATE && id != H5Z_FILTER_SHUFFLE) return false;
    filters.push_back(id);
  }
  const std::string where = file + ": " + what;
  hsize_t chunk[3] = {0, 0, 0};
  if (H5Pget_chunk(dcpl.id, rank, chunk) != rank) return false;
  const std::size_t element = H5Tget_size(memType);
  std::uint64_t chunkBytes = element;
  // The decode buffers are two chunks; voxpack writes 256 KiB chunks, h5py about 1 MiB.
  constexpr std::uint64_t kMaxChunk = std::uint64_t{256} << 20;
  for (int a = 0; a < rank; ++a) {
    if (chunk[a] == 0 || chunk[a] > kMaxChunk / chunkBytes)
      throw FormatError(where + ": chunks larger than the limit of 256 MiB");
    chunkBytes *= chunk[a];
  }
  std::vector<unsigned char> fill(element, 0);
  H5Pget_fill_value(dcpl.id, memType, fill.data());

  // Everything below works in 3-D: a rank-r dataset gets 3 - r leading axes of extent 1.
  const int lead = 3 - rank;
  hsize_t s3[3] = {0, 0, 0}, n3[3] = {1, 1, 1}, c3[3] = {1, 1, 1};
  for (int a = 0; a < rank; ++a) {
    s3[lead + a] = start[a];
    n3[lead + a] = count[a];
    c3[lead + a] = chunk[a];
  }
  for (int a = 0; a < 3; ++a)
    if (n3[a] == 0) return true;
  hsize_t first[3], last[3], idx[3];
  for (int a = 0; a < 3; ++a) {
    first[a] = s3[a] / c3[a];
    last[a] = (s3[a] + n3[a] - 1) / c3[a];
    idx[a] = first[a];
  }
  auto* dst = static_cast<unsigned char*>(out);
  std::vector<unsigned char> stored, decoded;
  const std::uint64_t maxStored = compressBound(static_cast<uLong>(chunkBytes)) + 64;
  for (;;) {
    hsize_t o3[3];
    for (int a = 0; a < 3; ++a) o3[a] = idx[a] * c3[a];
    unsigned mask = 0;
    haddr_t addr = HADDR_UNDEF;
    hsize_t size = 0;
    if (H5Dget_chunk_info_by_coord(ds, o3 + lead, &mask, &addr, &size) < 0)
      throw IoError(where + ": cannot locate a chunk (file truncated or corrupt?)");
    const unsigned char* src = nullptr;  // nullptr: the chunk was never written, so fill
    if (addr != HADDR_UNDEF) {
      bool deflated = false;
      for (std::size_t i = 0; i < filters.size(); ++i)
        deflated = deflated || (filters[i] == H5Z_FILTER_DEFLATE && !(mask & (1u << i)));
      if (size > (deflated ? maxStored : chunkBytes) || (!deflated && size != chunkBytes))
        throw FormatError(where + ": a chunk stores " + std::to_string(size) +
                          " bytes for a chunk of " + std::to_string(chunkBytes));
      stored.resize(static_cast<std::size_t>(size));
      std::uint32_t readMask = 0;
      if (H5Dread_chunk(ds, H5P_DEFAULT, o3 + lead, &readMask, stored.data()) < 0)
        throw IoError(where + ": cannot read a chunk (file truncated or corrupt?)");
      // The pipeline runs backwards on read: the last filter written is undone first.
      for (std::size_t i = filters.size(); i-- > 0;) {
        if (mask & (1u << i)) continue;
        if (filters[i] == H5Z_FILTER_DEFLATE) {
          decoded.resize(static_cast<std::size_t>(chunkBytes));
          if (!inflateExact(stored, decoded))
            throw FormatError(where + ": a deflated chunk does not inflate to its " +
                              std::to_string(chunkBytes) + " bytes");
          stored.swap(decoded);
        } else {
          unshuffle(stored, element);
        }
      }
      src = stored.data();
    }
    // The chunk's intersection with the box, one run along the last axis at a time.
    hsize_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(o3[a], s3[a]);
      hi[a] = std::min(o3[a] + c3[a], s3[a] + n3[a]);
    }
    const std::size_t run = static_cast<std::size_t>(hi[2] - lo[2]) * element;
    for (hsize_t z = lo[0]; z < hi[0]; ++z)
      for (hsize_t y = lo[1]; y < hi[1]; ++y) {
        const std::uint64_t o = ((z - s3[0]) * n3[1] + (y - s3[1])) * n3[2] + (lo[2] - s3[2]);
        unsigned char* d = dst + o * element;
        if (src) {
          const std::uint64_t c = ((z - o3[0]) * c3[1] + (y - o3[1])) * c3[2] + (lo[2] - o3[2]);
          std::memcpy(d, src + c * element, run);
        } else {
          for (std::size_t e = 0; e < run; e += element) std::memcpy(d + e, fill.data(), element);
        }
      }
    // Next chunk, last axis fastest.
    int a = 2;
    while (a >= 0 && ++idx[a] > last[a]) {
      idx[a] = first[a];
      --a;
    }
    if (a < 0) break;
  }
  return true;
}

std::string unavailableFilter(hid_t ds) {
  Id dcpl{H5Dget_create_plist(ds), H5Pclose};
  const int n = dcpl.ok() ? H5Pget_nfilters(dcpl.id) : 0;
  for (int i = 0; i < n; ++i) {
    unsigned flags = 0, config = 0, values[8];
    size_t nValues = 8;
    char name[64] = {0};
    const H5Z_filter_t id = H5Pget_filter2(dcpl.id, static_cast<unsigned>(i), &flags, &nValues,
                                           values, sizeof name, name, &config);
    if (id >= 0 && H5Zfilter_avail(id) <= 0)
      return std::string(name[0] ? name : "unnamed") + " (id " + std::to_string(id) + ")";
  }
  return {};
}

}  // namespace voxpack::hdf5guard
