// Variable-length strings: the global heap is checked before libhdf5 reads it.
//
// A variable-length string is stored as a 4-byte length and a global heap ID (the address
// of a heap collection, "GCOL", and an object index). libhdf5 1.10 trusts the collection:
// a free-space object of size 0 makes H5HG__cache_heap_deserialize loop forever (a fuzzed
// bed hung `voxpack info` in H5Aread -> H5T__conv_vlen -> H5HG_read), an object larger
// than the string's length overruns the conversion buffer, and an index past the objects
// reads outside the collection's table. So the raw IDs are read first (through a
// conversion to an opaque type that copies them out undecoded), and each collection is
// parsed here the way libhdf5 parses it, with every size checked against the file, before
// H5Aread/H5Dread may follow the IDs. docs/reliability.md, "Fuzzing".
#include <hdf5.h>

#include <cstring>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "hdf5_guard.hpp"
#include "hdf5_raw.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack::hdf5guard {
namespace {

using detail::Id;
using detail::le;
using detail::RawFile;

// One raw element: what libhdf5 stores for a variable-length string.
struct VlenRef {
  std::uint32_t length = 0;   // bytes of the string
  std::uint32_t index = 0;    // object index in the collection
  std::uint64_t address = 0;  // collection address (relative to the superblock), 0 = none
};
constexpr const char* kVlenRefTag = "voxpack:vlen-string-ref";

// Conversion function from a stored variable-length string to the VlenRef opaque type:
// copies the length, address and index out of the stored element without following them.
herr_t vlenToRef(hid_t src, hid_t dst, H5T_cdata_t* cdata, size_t nelmts, size_t bufStride,
                 size_t /*bkgStride*/, void* buf, void* /*bkg*/, hid_t /*dxpl*/) {
  switch (cdata->command) {
    case H5T_CONV_INIT: {
      cdata->need_bkg = H5T_BKG_NO;
      if (H5Tis_variable_str(src) <= 0 || H5Tget_class(dst) != H5T_OPAQUE ||
          H5Tget_size(dst) != sizeof(VlenRef))
        return -1;
      char* tag = H5Tget_tag(dst);
      const bool ours = tag && std::strcmp(tag, kVlenRefTag) == 0;
      H5free_memory(tag);
      // An 8..16-byte element: length (4), address (1..8), index (4).
      const std::size_t s = H5Tget_size(src);
      return ours && s > 8 && s <= 16 ? 0 : -1;
    }
    case H5T_CONV_CONV: {
      const std::size_t s = H5Tget_size(src);
      const std::size_t stride = bufStride ? bufStride : s;
      auto* bytes = static_cast<unsigned char*>(buf);
      // The source and destination sizes may differ (4-byte addresses): decode all first.
      std::vector<VlenRef> refs(nelmts);
      for (std::size_t n = 0; n < nelmts; ++n) {
        const unsigned char* e = bytes + n * stride;
        refs[n].length = static_cast<std::uint32_t>(le(e, 4));
        refs[n].address = le(e + 4, s - 8);
        refs[n].index = static_cast<std::uint32_t>(le(e + s - 4, 4));
      }
      const std::size_t out = bufStride ? bufStride : sizeof(VlenRef);
      for (std::size_t n = 0; n < nelmts; ++n)
        std::memcpy(bytes + n * out, &refs[n], sizeof(VlenRef));
      return 0;
    }
    case H5T_CONV_FREE:
      return 0;
    default:
      return -1;
  }
}

// The opaque memory type that H5Aread/H5Dread fill with VlenRefs (conversion registered
// once); the caller closes it.
hid_t vlenRefType() {
  static std::once_flag once;
  std::call_once(once, [] {
    Id vstr{H5Tcopy(H5T_C_S1), H5Tclose};
    H5Tset_size(vstr.id, H5T_VARIABLE);
    Id ref{H5Tcreate(H5T_OPAQUE, sizeof(VlenRef)), H5Tclose};
    H5Tset_tag(ref.id, kVlenRefTag);
    H5Tregister(H5T_PERS_SOFT, "voxpack_vlen_ref", vstr.id, ref.id, vlenToRef);
  });
  const hid_t ref = H5Tcreate(H5T_OPAQUE, sizeof(VlenRef));
  if (ref >= 0) H5Tset_tag(ref, kVlenRefTag);
  return ref;
}

// The global heap collections of one file, each parsed and checked the way
// H5HG__cache_heap_deserialize walks it: what would make that walk loop, or an object
// lying outside its collection or the collection outside the file, is refused.
class HeapCollections {
 public:
  HeapCollections(hid_t obj, const std::string& file) : raw_(obj, file) {}

  // The size of each object of the collection at `address`, by index (-1: no object).
  const std::vector<std::int64_t>& objectSizes(std::uint64_t address) {
    auto it = parsed_.find(address);
    if (it == parsed_.end()) it = parsed_.emplace(address, parse(address)).first;
    return it->second;
  }

 private:
  std::vector<std::int64_t> parse(std::uint64_t address) {
    const std::string where = "global heap collection at " + std::to_string(address);
    const std::size_t sizeofSize = raw_.sizeofSize();
    const std::uint64_t header = 8 + sizeofSize;     // "GCOL", version, 3 reserved, size
    const std::uint64_t objHeader = 8 + sizeofSize;  // index, refcount, 4 reserved, size
    const std::vector<unsigned char> head = raw_.read(address, header, where);
    if (std::memcmp(head.data(), "GCOL", 4) != 0 || head[4] != 1)
      raw_.fail(where + " has no valid signature");
    const std::uint64_t size = le(head.data() + 8, sizeofSize);
    // libhdf5 allocates the declared size before it reads; voxpack's strings are small.
    constexpr std::uint64_t kMaxCollection = std::uint64_t{256} << 20;
    if (size < header || size > raw_.size() || size > kMaxCollection)
      raw_.fail(where + " declares " + std::to_string(size) +
                " bytes, beyond the end of the file or the limit of 256 MiB");
    const std::vector<unsigned char> chunk = raw_.read(address, size, where);

    std::vector<std::int64_t> sizes;
    std::uint64_t p = header;
    while (p < size) {
      if (p + objHeader > size) break;  // too small for an object: trailing free space
      const unsigned char* o = chunk.data() + p;
      const auto idx = static_cast<std::size_t>(le(o, 2));
      const std::uint64_t objSize = le(o + 8, sizeofSize);
      // Object 0 is the free space, whose size includes its header and is not padded;
      // libhdf5 steps by it, so a size of 0 would never advance.
      const std::uint64_t need = objSize > size ? size
                                 : idx > 0      ? objHeader + ((objSize + 7) / 8) * 8
                                                : objSize;
      if (objSize > size || need == 0 || need > size - p)
        raw_.fail(where + ": object " + std::to_string(idx) + " of " + std::to_string(objSize) +
                  " bytes does not fit the collection");
      if (idx > 0) {
        if (sizes.size() <= idx) sizes.resize(idx + 1, -1);
        sizes[idx] = static_cast<std::int64_t>(objSize);
      }
      p += need;
    }
    return sizes;
  }

  RawFile raw_;
  std::unordered_map<std::uint64_t, std::vector<std::int64_t>> parsed_;
};

}  // namespace

void checkVlenStrings(hid_t obj, hid_t type, const std::string& file, const std::string& what,
                      std::size_t n, const std::function<herr_t(hid_t, void*)>& read) {
  auto fail = [&](const std::string& m) { throw FormatError(file + ": " + m); };
  Id base{H5Tget_super(type), H5Tclose};
  if (!base.ok() || H5Tget_size(base.id) != 1)
    fail(what + " is not a string of one-byte characters");
  const Id refType{vlenRefType(), H5Tclose};
  std::vector<VlenRef> refs(n);
  if (!refType.ok() || read(refType.id, refs.data()) < 0)
    fail("cannot read the string references of " + what);
  HeapCollections heaps(obj, file);
  for (const VlenRef& r : refs) {
    if (r.address == 0) continue;  // a null string: libhdf5 reads nothing
    const auto& sizes = heaps.objectSizes(r.address);
    if (r.index == 0 || r.index >= sizes.size() || sizes[r.index] < 0)
      fail(what + " refers to global heap object " + std::to_string(r.index) +
           ", which does not exist");
    if (static_cast<std::uint64_t>(sizes[r.index]) != r.length)
      fail(what + " declares a string of " + std::to_string(r.length) +
           " bytes stored in a heap object of " + std::to_string(sizes[r.index]));
  }
}

}  // namespace voxpack::hdf5guard
