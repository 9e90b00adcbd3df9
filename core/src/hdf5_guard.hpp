// Checks that stand between a hostile bed file and libhdf5 1.10.8 (internal to voxpack_core).
//
// Two classes of memory errors inside libhdf5 were found by fuzzing (docs/reliability.md,
// "Fuzzing"): a deflated chunk that inflates to fewer bytes than the chunk holds is copied
// out of its short buffer by H5Dread, and an attribute message whose data is declared larger
// than the message is copied past the end of the object header by every attribute call
// (H5Aexists, H5Aopen). Neither is checked by that libhdf5, so voxpack checks them itself.
#pragma once

#include <hdf5.h>

#include <cstddef>
#include <functional>
#include <string>

namespace voxpack::hdf5guard {

/// Parses the object header of `obj` from the file's bytes and throws FormatError("FILE: ...")
/// when an attribute message's name, datatype, dataspace and data do not fit the message, or
/// its datatype is not one voxpack writes (numbers, strings of one-byte characters).
void checkAttributeMessages(hid_t obj, const std::string& file, const std::string& what);

/// Reads the hyperslab [start, start + count) of `ds` into `out` (C order, memType elements)
/// by decoding every chunk here, each inflated to exactly its size. Returns false, reading
/// nothing, when the dataset is not of the kind this handles (not chunked; a filter other
/// than shuffle and deflate; a file type other than memType; `mpio`, a file opened through
/// MPI-IO), so the caller falls back to H5Dread. Throws FormatError on a bad chunk.
bool readChunksChecked(hid_t ds, hid_t memType, int rank, const hsize_t* start,
                       const hsize_t* count, void* out, bool mpio, const std::string& file,
                       const std::string& what);

/// Checks every variable-length string element that `read` (H5Aread or H5Dread of `obj`'s
/// `n` elements into the memory type it is given) yields against its global heap
/// collection, so that libhdf5's own read of them cannot loop or overrun; throws
/// FormatError("FILE: ...") naming `what`. The character size is checked first: libhdf5
/// allocates (length x character size) bytes per string with the size the file declares.
void checkVlenStrings(hid_t obj, hid_t type, const std::string& file, const std::string& what,
                      std::size_t n, const std::function<herr_t(hid_t, void*)>& read);

/// The name and id of the first filter of `ds`'s pipeline that this libhdf5 cannot decode
/// (e.g. h5py's lzf, "lzf (id 32000)"); empty when every filter is available.
std::string unavailableFilter(hid_t ds);

}  // namespace voxpack::hdf5guard
