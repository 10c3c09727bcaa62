"""Modal-test measurement: FRFs, modal parameters, peak levels, MAC/COMAC.

Modules
-------
frf
    H1 estimator with coherence (Sec. 5.4.1); the FRF type it returns,
    :class:`~vlab.io.frf.FRF`, is defined in :mod:`vlab.io.frf` and re-exported here.
modal
    Peak picking, half-power damping, peak level ratios (Tables 10, 19-21).
modal_fit
    Curve-fit modal parameters (rational fraction, LSCF).
decay
    Damping of a free decay (logarithmic decrement of the Hilbert envelope).
mac
    MAC matrix, COMAC, mode pairing.
shapes
    Mode shapes identified from the FRFs of one excitation point (residues by LSFD), MAC against a model.
instability
    Self-excited oscillations and growth in a recording (the loop went unstable).
transient
    Transient removal for periodic excitation (local polynomial method).
"""

from ..io.frf import FRF
from .frf import h1, measure_frfs
from .instability import InstabilityCheck, find_instability
from .mac import comac, mac, pair_modes
from .transient import PeriodicSpectra, periodic_spectra
from .decay import decay_damping
from .modal import average_peak_error, find_peaks, half_power_damping, peak_level_ratios, peak_levels
from .modal_fit import fit_modes
from .shapes import IdentifiedShapes, ShapeComparison, compare_shapes, identify_shapes

__all__ = [
    "FRF", "h1", "measure_frfs", "mac", "comac", "pair_modes", "find_peaks",
    "half_power_damping", "fit_modes", "decay_damping", "peak_levels",
    "peak_level_ratios", "average_peak_error", "find_instability", "InstabilityCheck",
    "periodic_spectra", "PeriodicSpectra", "identify_shapes", "compare_shapes", "IdentifiedShapes",
    "ShapeComparison",
]
