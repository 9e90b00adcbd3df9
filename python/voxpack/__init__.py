"""voxpack from Python: digital packing of particles in columns, ingest of MRI/XMT images,
structure statistics and comparison (docs/python.md).

The module is not a second implementation: ``pack``, ``ingest``, ``phantom``, ``compare``,
``flow`` and ``export`` run the CLI's own commands in this process (same parsing, same code, same
bytes), ``read_bed``/``write_bed`` are the C++ bed reader and writer, and ``stats`` calls
the statistics library function ``voxpack stats`` calls. Long calls release the GIL,
take ``threads=`` and ``progress=callable(done, total)``, and stop on Ctrl-C
(KeyboardInterrupt). Errors: ValueError (bad input; voxpack.InputError and its
subclasses), OSError (files; voxpack.IoError), RuntimeError (internal), with the CLI's
message text. Messages of the commands go to the ``logging`` logger "voxpack".

Arrays are C order [z][y][x], z the column axis; lengths in mm. Boolean arrays are read
with True = void (PoreSpy's convention); indicator arrays hold 1 = void, 0 = solid.
"""

from . import _voxpack
from ._bed import Bed, bed_datasets, read_bed, write_bed
from ._commands import Image, compare, ingest, pack, phantom, statistic_names, stats
from ._flow_export import export, flow

InputError = _voxpack.InputError
UsageError = _voxpack.UsageError
FormatError = _voxpack.FormatError
ResourceError = _voxpack.ResourceError
IoError = _voxpack.IoError
Cancelled = _voxpack.Cancelled

__version__ = _voxpack.version()

__all__ = ["Bed", "Image", "read_bed", "write_bed", "bed_datasets", "pack", "stats", "ingest",
           "phantom", "compare", "flow", "export", "statistic_names", "InputError", "UsageError", "FormatError",
           "ResourceError", "IoError", "Cancelled", "__version__"]
