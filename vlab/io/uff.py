"""Universal File Format (UFF) input/output with pyuff.

Formats written and read:

* **Recordings** — dataset 58, function type 1 (time response), one record
  per channel: ``rsp_node`` = point id, ``rsp_dir`` = 3 (+Z, out of plane),
  ordinate force [N] (specific data type 13), velocity [m/s] (11),
  displacement [m] (8) or acceleration [m/s^2] (12); abscissa time [s] (17),
  evenly spaced.
* **FRFs** — dataset 58, function type 4, ``ref_node`` = force point,
  ``rsp_node`` = response point, complex ordinate per force (denominator
  type 13), explicit frequency abscissa [Hz]; the coherence follows each FRF
  as a function type 6 record with the same nodes.
* **Mode shapes** — dataset 55, normal modes (analysis type 2, real shapes)
  or complex modes (type 3), 3-DOF nodal data with the shape in Z.

vlab writes datasets 58 in binary form ("58b", doubles) by default, so a
written file reloads bit-identical. Two values the fixed-width UFF header
keeps only to 6 digits are stored exactly in ID lines: ``id4 =
"dt_s=<repr>"`` for time step; and ``id5 = "record i of n"`` lets the
reader detect a file truncated at a record boundary. ID line 1 holds the
channel name (``force4``), or ``output/input`` for an FRF. Dataset 55 is
ASCII ``E13.5``: mode shapes keep 6 significant digits.

A recording's metadata goes to a JSON sidecar next to the UFF file
(``run.uff`` -> ``run.uff.json``), because UFF ID lines hold 80 characters.

Writing never replaces an existing file unless ``overwrite=True``; files are
written to a temporary name and moved into place, so a failed write leaves
no partial file.

Layout: time histories in :mod:`vlab.io.uff_time`, FRFs in
:mod:`vlab.io.uff_frf`, mode shapes (dataset 55) in :mod:`vlab.io.uff55`
(all re-exported here), shared file handling and header checks in
:mod:`vlab.io.uff_files`, units in :mod:`vlab.io.uff_units`.

Source: UFF dataset descriptions (SDRC/I-DEAS, https://www.ceas3.uc.edu/sdrluff/);
pyuff (Slavič et al., https://github.com/ladisk/pyuff).
"""

from .uff55 import ModeShapes, read_mode_shapes, write_mode_shapes
from .uff_files import SPEC_DATA_TYPE, sidecar_path
from .uff_frf import read_frfs, write_frfs
from .uff_time import MIN_SAMPLES, read_recording, write_recording

__all__ = ["SPEC_DATA_TYPE", "MIN_SAMPLES", "sidecar_path", "write_recording", "read_recording", "write_frfs",
           "read_frfs", "ModeShapes", "write_mode_shapes", "read_mode_shapes"]
