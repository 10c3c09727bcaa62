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


class OptionError(VlabError, ValueError):
    """A command-line option has an invalid value (non-finite, out of range, contradictory); names the option."""


class OutputError(VlabError, ValueError):
    """An output file or folder cannot be written as asked (exists, parent missing, not writable); names the path."""


class ResourceError(VlabError, ValueError):
    """A run would need more memory than the machine has available; says how much it would need."""


#: Exception classes that mean bad input (command-line exit status 2); every other
#: :class:`VlabError` (:class:`SimulationError`, :class:`MeasurementError` during a run)
#: means a failed run (exit status 1).
BAD_INPUT_ERRORS = (SpecError, ModelError, ReductionError, DataFileError, OptionError, OutputError, ResourceError)
