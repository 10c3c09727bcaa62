"""StructureSpec: the one definition of a laboratory structure.

``assets/structures/<name>.toml`` describes a structure once; the FE model
(:mod:`vlab.fe`) and the MuJoCo plant (:mod:`vlab.sim`) are both built from
the :class:`vlab.spec.StructureSpec` loaded here. Every physical value in the file is an
inline table ``{ value = ..., unit = "...", source = "..." }``; the source is a
section or table of the dissertation, ``"assumed: <reason>"`` or
``"calibrated: <data>"``. Values are converted to SI on loading.

Coordinates: the structure lies in the plane (x, y), y up; ``w`` is the
out-of-plane (z) translation, ``rx``/``ry`` the rotations about x and y.

Errors: :class:`vlab.errors.SpecError` naming the file and the dotted field.

The package's modules:

- :mod:`vlab.spec.structure` -- the dataclasses (:class:`vlab.spec.StructureSpec` and its parts) and the asset folders
- :mod:`vlab.spec.reader` -- reading one table: field-path errors, units, plausible ranges
- :mod:`vlab.spec.geometry` -- the tables of the structure (points, sections, members, strings, masses, ...)
- :mod:`vlab.spec.settings` -- the tables of its test, damping, references, reduction and design
- :mod:`vlab.spec.changes` -- the change tables a diagnosis appends (``vlab update``)
- :mod:`vlab.spec.hardware` -- the ``[hardware]`` table: per-channel gains, delays and lags of coils and sensors
- :mod:`vlab.spec.load` -- :func:`vlab.spec.load_spec` and :func:`vlab.spec.spec_from_dict`
- :mod:`vlab.spec.edit` -- :func:`vlab.spec.structure_identity` and :func:`vlab.spec.with_quantity`
"""

from .changes import CHANGE_TABLES, apply_change_tables, damping_of, release_supports, split_segments
from .edit import structure_identity, with_quantity
from .hardware import HARDWARE_TABLES, Hardware, input_gains, output_gains
from .geometry import MAX_COORDINATE_M, MAX_ELEMENTS_PER_SEGMENT
from .load import load_spec, spec_from_dict
from .reader import PLAUSIBLE_RANGES
from .settings import (DESIGN_FIELDS, DESIGN_OPTIONS, DESIGN_UNITS, DESIGN_WEIGHTS_SI, DESIGN_WEIGHTS_THESIS,
                       MAX_TEST_BAND_HZ, RESPONSE_QUANTITIES)
from .structure import (ASSETS_DIR, DATA_DIR, DOF_NAMES, STRUCTURES_DIR, Crosspiece, Damping, Instrumentation,
                        LumpedMass, Member, ModelFormDeclared, Quantity, RigidInsert, Section, Spring, StringElement,
                        StructureSpec, StructureTest, Support)

__all__ = [
    "ASSETS_DIR", "CHANGE_TABLES", "HARDWARE_TABLES", "Hardware", "DATA_DIR", "DESIGN_FIELDS", "DESIGN_OPTIONS",
    "DESIGN_UNITS", "DESIGN_WEIGHTS_SI", "DESIGN_WEIGHTS_THESIS", "DOF_NAMES", "MAX_COORDINATE_M",
    "MAX_ELEMENTS_PER_SEGMENT", "MAX_TEST_BAND_HZ", "PLAUSIBLE_RANGES", "RESPONSE_QUANTITIES", "STRUCTURES_DIR",
    "Crosspiece", "Damping", "Instrumentation", "LumpedMass", "Member", "ModelFormDeclared", "Quantity",
    "RigidInsert", "Section", "Spring", "StringElement", "StructureSpec", "StructureTest", "Support",
    "apply_change_tables", "damping_of", "input_gains", "load_spec", "output_gains", "release_supports", "spec_from_dict", "split_segments",
    "structure_identity", "with_quantity",
]
