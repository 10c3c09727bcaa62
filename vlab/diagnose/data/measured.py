"""Measured data for a diagnosis: measured FRFs and modal tables, and their referral to the model.

Three inputs become one of two types:

- UFF 58 time histories (function type 1) as ``vlab experiment`` writes them, and UFF 58 FRFs
  (function type 4, optionally with coherence, type 6), become :class:`FrfData`: FRFs from one
  excitation point to velocity outputs with the variance of each line
  (:mod:`vlab.diagnose.data.frfestimate`);
- a CSV modal table (``mode``, ``frequency_hz``, ``damping_ratio`` and optional shape columns
  ``shape_<point>``; the dissertation's ``experimental_hz`` and ``damping_experimental`` of Table 3
  accepted; ``#`` lines are comments) becomes :class:`ModalData` (:mod:`vlab.diagnose.data.modalcsv`).

Which a file holds is decided by :mod:`vlab.diagnose.data.readers`. :func:`refer_to_model` refers
measured FRFs to the model through a baseline recording of the unmodified structure.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import DataFileError
from ...io.recording import Recording

#: Lines whose relative noise exceeds this (SNR below ~2) are not used.
MAX_RELATIVE_NOISE = 0.5


@dataclass(frozen=True)
class FrfData:
    """Measured FRFs from one excitation point to several velocity outputs.

    Attributes
    ----------
    source : str
        File the data came from.
    kind : {"recording", "frf"}
    freq_hz : ndarray, shape (n_f,)
        Lines [Hz].
    h : ndarray, complex, shape (n_f, n_o)
        Velocity per force [(m/s)/N].
    var : ndarray, shape (n_f, n_o)
        Variance of ``h`` (complex: ``E|h - h_true|^2``) [((m/s)/N)^2].
    excitation_point : int
    output_points : tuple of int, length n_o
    force_amplitude : ndarray, shape (n_f,) or None
        One-sided amplitude of the excitation at each line [N] (recordings).
    velocity_rms : dict
        Output point -> RMS velocity [m/s] over the analysed periods (recordings).
    recording : Recording or None
        The time histories (recordings).
    analysed_from_s : float
        Start of the analysed part of the recording [s] (transient dropped).
    notes : list of str
        What was assumed on the way (resolution, settling, noise estimate).
    periodic : bool
        Estimated period by period (periodic excitation) rather than by H1 with a Hann window.
    h_recorded : ndarray, complex, shape (n_f, n_o) or None
        The FRFs as recorded when ``h`` has been referred to the model through a
        baseline recording (:func:`refer_to_model`); None otherwise.
    var_recorded : ndarray, shape (n_f, n_o) or None
        The variance of ``h_recorded`` (the recording's own noise) [((m/s)/N)^2].
    var_baseline : ndarray, shape (n_f, n_o) or None
        The variance of the baseline's FRFs (its own noise) when ``h`` has been
        referred through a baseline [((m/s)/N)^2]; None otherwise.
    h_baseline : ndarray, complex, shape (n_f, n_o) or None
        The baseline's FRFs when ``h`` has been referred through one (a measured baseline or a replay);
        None otherwise.
    var_dof : float or None
        Effective real degrees of freedom of ``var`` when it is estimated from
        the data (period-to-period scatter, pooled over neighbouring lines:
        :func:`~vlab.diagnose.data.frfestimate.pooled_dof`); None when it is taken as known.
    var_steady : ndarray, shape (n_f, n_o) or None
        A periodic recording's variance without the uncertainty of the transient's removal
        (:mod:`vlab.measure.transient`), which ``var`` includes [((m/s)/N)^2]: what is left when the
        reference carries the same transient (``same_transient``); None otherwise.
    same_transient : bool
        This FrfData is a reference replayed from rest through the recording's own periods: it carries the
        recording's transient, which then cancels in :func:`refer_to_model`.
    var_distortion : ndarray, shape (n_f, n_o) or None
        The relative variance [1] of the reference replay's own level dependence that ``var`` includes
        (:func:`vlab.diagnose.data.reference.with_replay_distortion`); None where none is included.
    records : (tuple of int, int) or None
        A transient excitation's records (their first samples on the recording's clock) and the samples the
        force window keeps (:func:`vlab.measure.impact.transient_h1`), so that a simulation of the test is
        analysed over the same records; None for other excitations.
    """

    source: str
    kind: str
    freq_hz: np.ndarray
    h: np.ndarray
    var: np.ndarray
    excitation_point: int
    output_points: tuple[int, ...]
    force_amplitude: np.ndarray | None = None
    velocity_rms: dict = field(default_factory=dict)
    recording: Recording | None = None
    analysed_from_s: float = 0.0
    notes: list = field(default_factory=list)
    periodic: bool = True
    h_recorded: np.ndarray | None = None
    var_recorded: np.ndarray | None = None
    var_baseline: np.ndarray | None = None
    h_baseline: np.ndarray | None = None
    var_dof: float | None = None
    var_steady: np.ndarray | None = None
    same_transient: bool = False
    records: tuple | None = None
    var_distortion: np.ndarray | None = None

    def as_recorded(self) -> tuple[np.ndarray, np.ndarray]:
        """The FRFs as recorded and their variance, shapes (n_f, n_o): ``h_recorded`` and ``var_recorded``
        where these data were referred to the model through a reference (``var`` where the recording's own
        variance was not kept), else ``h`` and ``var``.

        Returns
        -------
        (ndarray, ndarray)
            Complex FRFs [(m/s)/N] and their variance [((m/s)/N)^2].
        """
        if self.h_recorded is not None:
            return self.h_recorded, (self.var_recorded if self.var_recorded is not None else self.var)
        return self.h, self.var

    @property
    def sigma_rel(self) -> np.ndarray:
        """Relative standard deviation ``sqrt(var) / |h|``, shape (n_f, n_o)."""
        return np.sqrt(self.var) / np.maximum(np.abs(self.h), 1e-300)


@dataclass(frozen=True)
class ModalData:
    """A measured modal table.

    Attributes
    ----------
    source : str
    modes : ndarray of int, shape (n_m,)
        Mode numbers as given.
    freq_hz : ndarray, shape (n_m,)
        Natural frequencies [Hz].
    damping : ndarray, shape (n_m,)
        Damping ratios (NaN where not given).
    shapes : ndarray, shape (n_p, n_m) or None
        Mode shapes at ``shape_points``.
    shape_points : tuple of int
    notes : list of str
    kind : str
        Always ``"modal"``.
    freq_sigma_hz : ndarray, shape (n_m,) or None
        Standard uncertainty of each frequency [Hz] (column ``frequency_sigma_hz``; NaN where blank).
    damping_sigma : ndarray, shape (n_m,) or None
        Standard uncertainty of each damping ratio [-] (column ``damping_sigma``; NaN where blank).
    freq_resolution_hz : ndarray, shape (n_m,) or None
        The resolution each frequency is printed to [Hz] (one unit in its last digit,
        :func:`vlab.diagnose.model.modelform.printed_resolution`).
    damping_resolution : ndarray, shape (n_m,) or None
        The resolution each damping ratio is printed to [-] (NaN where not given).
    reference_hz : ndarray, shape (n_m,) or None
        A reference model's frequency of each mode [Hz] (the column named by
        ``reference_column`` of :func:`~vlab.diagnose.data.modalcsv.read_modal_csv`, e.g. a published
        analysis): the data are then compared with it, vlab's model predicting
        only what a change does (:meth:`vlab.diagnose.problem.residuals.Problem`).
    reference_resolution_hz : ndarray, shape (n_m,) or None
        The resolution the reference frequencies are printed to [Hz].
    reference_column : str or None
        The column ``reference_hz`` came from (kept when the table has been referred, and
        ``reference_hz`` set to None).
    """

    source: str
    modes: np.ndarray
    freq_hz: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray | None = None
    shape_points: tuple[int, ...] = ()
    notes: list = field(default_factory=list)
    kind: str = "modal"
    freq_sigma_hz: np.ndarray | None = None
    damping_sigma: np.ndarray | None = None
    freq_resolution_hz: np.ndarray | None = None
    damping_resolution: np.ndarray | None = None
    reference_hz: np.ndarray | None = None
    reference_resolution_hz: np.ndarray | None = None
    reference_column: str | None = None


def refer_to_model(data: FrfData, baseline: FrfData, h_model: np.ndarray) -> FrfData:
    """Refer measured FRFs to the model through a baseline recording of the unmodified structure.

    ``H_ref = H_meas * H_model / H_baseline`` line by line: the ratio of the
    recording to the baseline (the change since the baseline) is kept and the
    model-form error shared by both (the model's offsets against this plant,
    present before any change) is removed to first order -- the reference-state
    idea of vibration-based damage detection (Doebling et al., *Damage
    identification and health monitoring of structural and mechanical systems
    from changes in their vibration characteristics*, LA-13070-MS, 1996, Sec. 3).
    Variances add in relative terms (the recording's without the uncertainty of its transient's removal
    when the baseline carries the same transient, ``baseline.same_transient``), and the referral's
    second-order error,
    ``|ln(H_model / H_baseline)| * |ln(H_meas / H_baseline)|`` (model-form
    error times change), is added as a systematic relative variance.

    Parameters
    ----------
    data, baseline : FrfData
        The recording under diagnosis and the baseline of the same test (same
        lines, excitation point and outputs).
    h_model : ndarray, complex, shape (n_f, n_o)
        The nominal model's FRFs on the data's lines [(m/s)/N].

    Returns
    -------
    FrfData
        ``h`` referred to the model, ``var`` propagated, ``h_recorded`` and
        ``var_recorded`` the recorded FRFs and their noise, ``var_baseline``
        the baseline's noise; a note says so.

    Raises
    ------
    DataFileError
        The baseline has other lines, another excitation point or other outputs
        (names the baseline file).
    """
    if (baseline.excitation_point != data.excitation_point
            or tuple(baseline.output_points) != tuple(data.output_points)):
        raise DataFileError(
            f"{baseline.source}: baseline excites point {baseline.excitation_point} and measures "
            f"{list(baseline.output_points)}; the recording {data.source} excites {data.excitation_point} and "
            f"measures {list(data.output_points)}: a baseline must be the same test")
    if baseline.freq_hz.shape != data.freq_hz.shape or not np.allclose(baseline.freq_hz, data.freq_hz,
                                                                       rtol=1e-9, atol=1e-9):
        raise DataFileError(
            f"{baseline.source}: baseline lines ({baseline.freq_hz.size} from {baseline.freq_hz[0]:g} Hz, "
            f"step {np.median(np.diff(baseline.freq_hz)):g} Hz) differ from the recording's "
            f"({data.freq_hz.size} from {data.freq_hz[0]:g} Hz): use the same excitation and resolution")
    own_var = data.var_steady if baseline.same_transient and data.var_steady is not None else data.var
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(np.abs(baseline.h) > 0, h_model / baseline.h, 0.0)
        # the referral is exact to first order; its second-order error is the product of the
        # model-form error and the change (ln of each ratio), kept as a systematic variance
        cross = np.abs(np.log(ratio)) * np.abs(np.log(data.h / baseline.h))
        rel_var = own_var / np.maximum(np.abs(data.h) ** 2, 1e-300) + \
            baseline.var / np.maximum(np.abs(baseline.h) ** 2, 1e-300) + np.where(np.isfinite(cross), cross, 0.0) ** 2
    h = data.h * ratio
    note = (f"referred to the model through the baseline {baseline.source}: H = H_recorded * H_model / "
            "H_baseline (the model-form error present in the baseline is removed to first order)")
    return replace(data, h=h, var=rel_var * np.abs(h) ** 2, h_recorded=data.h, var_recorded=own_var,
                   var_baseline=baseline.var, h_baseline=baseline.h, var_steady=None, notes=list(data.notes) + [note])
