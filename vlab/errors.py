"""Named exceptions of vlab.

Every error raised for bad user input subclasses :class:`VlabError` and one of
the built-in ``ValueError``/``TypeError``/``RuntimeError`` so that callers can
catch either. Messages name the file, field, point id or DOF concerned.
"""

from __future__ import annotations


class VlabError(Exception):
    """Base class of all vlab errors."""


class SpecError(VlabError, ValueError):
    """A structure definition (TOML) is malformed, incomplete or unphysical.

    The message names the file and the dotted field path.
    """


class ModelError(VlabError, ValueError):
    """A model cannot be built or analysed (unknown point id, singular matrix, ...)."""


class ReductionError(VlabError, ValueError):
    """A model reduction is impossible for the chosen master set (names the DOFs)."""


class SimulationError(VlabError, RuntimeError):
    """A simulation diverged or cannot be run as configured."""


class MeasurementError(VlabError, ValueError):
    """Recorded data cannot be analysed as requested (too short, NaN, clipped, ...)."""


class DataFileError(VlabError, ValueError):
    """A data file (UFF, CSV, MJCF) is missing, unreadable or inconsistent (names file and channel)."""
