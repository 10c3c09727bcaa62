"""The reference a recording is compared with: the recording's own settings, and its replay on the nominal plant.

For a time-history recording the reference is, by default,
the *simulation*: the recorded force is played back through vlab's own
nominal plant (the plant the recording names, MuJoCo by default) with the
controller and the hardware chain of the recording, and the recording is
referred to the FE model through that replay
(:func:`vlab.diagnose.data.measured.refer_to_model`, ``H = H_rec * H_model / H_replay``).
The FE model stays the fast surrogate the effects are fitted on; the
MuJoCo/FE model-form difference is the ratio ``H_model / H_replay``, measured
on the nominal replay, not absorbed by an effect. A *measured* baseline
(``--baseline``) replaces the replay.

The replay is made without sensor noise: the only noise in the comparison
is the recording's own (nothing of the recording's noise realisation is
borrowed).

The recording's metadata (the sidecar ``recording.uff.json`` that ``vlab
experiment`` writes: structure, controller, reduction, seed, plant, hardware
chain) supplies what the options leave unsaid; an option that contradicts it
is refused unless ``force``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import DataFileError, OptionError
from ...io.setup_file import CHAIN_KEYS
from ...lab.loop import HardwareChain
from ..model.labmodel import LabState, predict_frf
from .measured import FrfData, refer_to_model

#: The ``plant`` metadata of ``vlab experiment`` -> the replay's plant kind.
RECORDED_PLANTS = {"MuJoCo plant": "mujoco", "MuJoCo plant (MJCF)": "mujoco", "linear FE model": "linear"}

#: Seed of every replay and validation rerun. Their chains carry no sensor noise, so it draws nothing;
#: it is fixed, not the recording's seed, so that nothing of the recording's realisation is reused.
RERUN_SEED = 0


@dataclass(frozen=True)
class RecordedSetup:
    """What ran during a recording: options and metadata reconciled (:func:`recorded_setup`).

    Attributes
    ----------
    controller : str
        ``"none"`` (open loop) or a thesis controller name.
    reduction : str or None
        Design model of the controller (None: the design module's default for the structure).
    seed : int
        Seed of the controller design's multi-start.
    plant : {"mujoco", "linear"} or None
        Plant that made the recording (None: not said).
    chain : dict
        Hardware-chain settings recorded (:data:`~vlab.io.setup_file.CHAIN_KEYS`; SI, periods for the delay).
    notes : tuple of str
        Where each value came from, when not from an option.
    """

    controller: str
    reduction: str | None
    seed: int
    plant: str | None
    chain: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()


def _same(key: str, a, b) -> bool:
    """Whether two metadata values say the same (plants by the plant they name, numbers to 1e-9)."""
    if key == "plant":
        return RECORDED_PLANTS.get(a, a) == RECORDED_PLANTS.get(b, b)
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return abs(float(a) - float(b)) <= 1e-9 * max(abs(float(a)), abs(float(b)), 1.0)
    return a == b


def with_test_setup(meta: dict, setup_meta: dict, source: str, setup_file: str, *,
                    force: bool = False) -> tuple[dict, tuple[str, ...]]:
    """A recording's metadata completed by its test setup (``vlab diagnose --test``).

    Parameters
    ----------
    meta : dict
        The recording's own metadata (its sidecar; empty for an acquisition system's file).
    setup_meta : dict
        The test setup's fields in the sidecar's form (:attr:`vlab.io.setup_file.RecordingSetup.metadata`).
    source, setup_file : str
        The recording's and the test setup's files (for messages).
    force : bool
        Where both say a field and disagree, take the test setup's (said in a note).

    Returns
    -------
    metadata : dict
        The union; a ``chain`` merged field by field.
    notes : tuple of str
        The fields taken from the test setup over the recording's.

    Raises
    ------
    OptionError
        A field both give with different values, without ``force`` (names both files, the field and values).
    """
    out, notes = dict(meta), []
    flat_rec = {**{k: v for k, v in meta.items() if k != "chain"},
                **{f"chain.{k}": v for k, v in dict(meta.get("chain") or {}).items()}}
    flat_set = {**{k: v for k, v in setup_meta.items() if k != "chain"},
                **{f"chain.{k}": v for k, v in dict(setup_meta.get("chain") or {}).items()}}
    for key, v in flat_set.items():
        rec = flat_rec.get(key)
        if rec is not None and not _same(key, rec, v):
            if not force:
                raise OptionError(f"{setup_file}: {key} {v!r} contradicts {source}: its metadata says {rec!r} "
                                  "(correct the test setup, or add --force to use its value)")
            notes.append(f"{key} {v!r} from the test setup {setup_file} as forced, although the recording's "
                         f"metadata says {rec!r}")
        if key.startswith("chain."):
            out["chain"] = {**dict(out.get("chain") or {}), key[len("chain."):]: v}
        else:
            out[key] = v
    return out, tuple(notes)


def recorded_setup(meta: dict, source: str, *, controller: str | None, seed: int | None,
                   plant: str | None, force: bool = False) -> RecordedSetup:
    """Reconcile the diagnosis options with a recording's metadata.

    Parameters
    ----------
    meta : dict
        The recording's metadata (may be empty: a file from another tool).
    source : str
        The recording's file name (for messages).
    controller : str or None
        ``--controller`` (None: not given).
    seed : int or None
        ``--seed`` (None: not given).
    plant : {"linear", "mujoco"} or None
        ``--plant`` when given explicitly (None: ``auto``).
    force : bool
        Use the options where they contradict the metadata (said in a note).

    Returns
    -------
    RecordedSetup

    Raises
    ------
    OptionError
        An option contradicts the metadata and ``force`` is False: names the
        option, both values and the file.
    DataFileError
        A metadata field of the wrong type (names the file and field).
    """
    notes: list[str] = []

    def pick(option: str, given, key: str, recorded):
        if recorded is None:
            return given
        if given is None:
            notes.append(f"{key} {recorded!r} from the recording's metadata")
            return recorded
        if given != recorded:
            if not force:
                raise OptionError(f"{option} {given!r} contradicts {source}: its metadata says {key} {recorded!r} "
                                  f"(omit {option} to use the recording's, or add --force to diagnose with "
                                  f"{given!r})")
            notes.append(f"{key} {given!r} as forced, although the recording's metadata says {recorded!r}")
        return given

    rec_controller = meta.get("controller")
    if rec_controller is not None and not isinstance(rec_controller, str):
        raise DataFileError(f"{source}: metadata field 'controller': expected a name, got {rec_controller!r}")
    rec_seed = meta.get("seed")
    if rec_seed is not None and (isinstance(rec_seed, bool) or not isinstance(rec_seed, int)):
        raise DataFileError(f"{source}: metadata field 'seed': expected an integer, got {rec_seed!r}")
    rec_plant = meta.get("plant")
    rec_plant = RECORDED_PLANTS.get(rec_plant) if isinstance(rec_plant, str) else None
    chosen_controller = pick("--controller", controller, "controller", rec_controller) or "none"
    chosen_seed = pick("--seed", seed, "seed", rec_seed)
    chosen_plant = pick("--plant", plant, "plant", rec_plant)
    reduction = meta.get("reduction")
    if reduction is not None and not isinstance(reduction, str):
        raise DataFileError(f"{source}: metadata field 'reduction': expected a name, got {reduction!r}")
    if chosen_controller != rec_controller:
        reduction = None  # the recorded reduction belongs to the recorded controller
    chain = {}
    raw = meta.get("chain") or {}
    if not isinstance(raw, dict):
        raise DataFileError(f"{source}: metadata field 'chain': expected a table, got {raw!r}")
    for k in CHAIN_KEYS:
        v = raw.get(k)
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
            raise DataFileError(f"{source}: metadata field 'chain.{k}': expected a non-negative number, got {v!r}")
        chain[k] = float(v)
    return RecordedSetup(chosen_controller, reduction, 0 if chosen_seed is None else int(chosen_seed),
                         chosen_plant, chain, tuple(notes))


def recorded_chain(setup: RecordedSetup, period_s: float) -> HardwareChain:
    """The nominal hardware chain of a recording: the Sec. 5.3 chain with the settings its metadata records.

    Parameters
    ----------
    setup : RecordedSetup
        Its ``chain`` (:data:`~vlab.io.setup_file.CHAIN_KEYS`) overrides the Sec. 5.3 defaults.
    period_s : float
        Controller sampling period [s] (the recording's sample interval).

    Returns
    -------
    HardwareChain
        Without sensor noise (a model's chain).
    """
    return replace(HardwareChain(period_s=period_s), **setup.chain)


def replay_reference(data: FrfData, nominal: LabState, plant: str,
                     guard_s: float | None = None, level: float = 1.0) -> tuple[FrfData, object, str]:
    """Play the recorded force back through the nominal plant: the reference a recording is referred through.

    The replay starts warm the lab's settling time (``guard_s``) before the
    analysed part, as the validation reruns do
    (:func:`vlab.diagnose.data.warmstart.recorded_window`). Where the recording dropped
    less than that, the replay starts as the recording did
    (:func:`vlab.diagnose.data.warmstart.starts_at_rest`): at rest, through all the analysed periods (their
    transient is then in both and cancels), or warm at the first tick. It runs
    without sensor noise; its FRFs on the data's lines are those of
    :func:`vlab.diagnose.data.replay.frf_of`.

    Parameters
    ----------
    data : FrfData
        From a recording (``data.recording`` set; its force channel is played back).
    nominal : LabState
        The nominal lab: structure, controller and chain of the recording.
    plant : {"mujoco", "linear"}
    guard_s : float, optional
        Time [s] simulated after the warm start before the analysed part, when shorter than a period
        (:func:`vlab.diagnose.data.warmstart.guard_ticks`).
    level : float
        The force played back is the recorded one times ``level`` [1], > 0, with the lab's own nonlinear
        elements scaled with it (:func:`vlab.diagnose.data.replay.at_amplitude`); the FRFs are per newton.

    Returns
    -------
    reference : FrfData
        The replay's FRFs on the data's lines, shape (n_f, n_o), zero variance
        (a noise-free simulation); ``same_transient`` when it ran from rest through the recording's periods.
    rec : Recording
        The replay (to be reused as the validation's nominal rerun).
    kind : str
        The plant, in words.

    Raises
    ------
    ModelError
        The plant cannot be built.
    SimulationError
        The replay diverged.
    """
    from .replay import at_amplitude, expectation, frf_of, rerun, rerun_split
    from .warmstart import recorded_window

    rec = data.recording
    force = np.asarray(rec[f"force{data.excitation_point}"])
    nominal = expectation(nominal)  # noise-free, as its zero variance says
    if level != 1.0:
        nominal, force = at_amplitude(nominal, level), force * level
    start, period, stop = recorded_window(data, rec.dt_s, guard_s=guard_s)
    first = int(round(data.analysed_from_s / rec.dt_s))
    if plant == "mujoco" and period and start < first:  # over both cores
        run = rerun_split(nominal, force, excitation_point=data.excitation_point,
                          measured_points=tuple(data.output_points), plant=plant, seed=RERUN_SEED, start=start,
                          first=first, period=period, stop=stop)
        kind = "MuJoCo plant" if nominal.mjcf is None else f"MuJoCo plant of {nominal.mjcf}"
    else:
        run, kind = rerun(nominal, force, excitation_point=data.excitation_point,
                          measured_points=tuple(data.output_points), plant=plant, seed=RERUN_SEED, start=start,
                          period=period, stop=stop)
    h = frf_of(run, data)  # per newton at any level: the force is the one played back
    ref = replace(data, source=f"the nominal {kind}'s replay of the recorded force", h=h, var=np.zeros(h.shape),
                  recording=None, notes=[], h_recorded=None, var_recorded=None, var_baseline=None,
                  var_steady=None, same_transient=bool(data.periodic and start == 0 and not period))
    return ref, run, kind



def shares_excitation_record(data: FrfData, baseline) -> bool:
    """Whether a baseline recording was excited by the recording's own force record (the same samples).

    Only then does the comparison without the model-error floor hold
    (:func:`vlab.diagnose.fit.rules.changed_beyond_noise`): its noise is the
    period-to-period scatter, which leaves out what differs from one
    realisation of a random-phase multisine to another at the same spectrum
    -- the stochastic nonlinear distortions of a weakly nonlinear plant (Pintelon
    and Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.,
    Wiley 2012, Sec. 3.4) -- so a reference excited by another record is compared
    within the floor only. The replay shares the record by construction.

    Parameters
    ----------
    data : FrfData
        From a recording (``data.recording`` holds the force channel).
    baseline : Recording or None
        The baseline's time histories (None: FRFs only, the record unknown).

    Returns
    -------
    bool
        True when both force channels of the excitation point hold the same samples
        (relative tolerance 1e-9 of the force's RMS).
    """
    if baseline is None or data.recording is None:
        return False
    name = f"force{data.excitation_point}"
    if name not in baseline:
        return False
    a, b = np.asarray(data.recording[name]), np.asarray(baseline[name])
    if a.shape != b.shape:
        return False
    scale = float(np.sqrt(np.mean(a ** 2))) or 1.0
    return bool(np.max(np.abs(a - b)) <= 1e-9 * scale)


def referred_through_replay(data: FrfData, nominal: LabState, plant: str,
                            guard_s: float | None = None) -> tuple[FrfData, object, str]:
    """``data`` referred to the model ``nominal`` through its replay on ``plant``:
    ``H = H_recorded H_model / H_replay`` (:func:`replay_reference`, then
    :func:`vlab.diagnose.data.measured.refer_to_model`).

    Parameters
    ----------
    data : FrfData
        From a recording (``data.recording`` set), not yet referred.
    nominal : LabState
        The lab the data are referred to (its FE model predicts ``H_model``) and replayed on.
    plant : {"mujoco", "linear"}
    guard_s : float, optional
        As :func:`replay_reference`.

    Returns
    -------
    referred : FrfData
        Shape (n_f, n_o) FRFs [(m/s)/N] as :func:`~vlab.diagnose.data.measured.refer_to_model` returns them.
    rec : Recording
        The replay.
    kind : str
        The plant, in words.

    Raises
    ------
    ModelError, SimulationError
        As :func:`replay_reference`.
    """
    base, rec, kind = replay_reference(data, nominal, plant, guard_s=guard_s)
    h_nom = predict_frf(nominal, data.freq_hz, excitation_point=data.excitation_point, output_points=data.output_points)
    return refer_to_model(data, base, h_nom), rec, kind


def with_replay_distortion(data: FrfData, nominal: LabState, plant: str,
                           guard_s: float | None = None) -> tuple[FrfData, float, object]:
    """``data`` referred through a replay (:func:`referred_through_replay`) with the replay plant's own level
    dependence added to its variance: the reference's model form, where the data are of a real structure.

    A MuJoCo plant is not exactly linear (its hinge chains' finite rotations): a random-phase multisine
    played through it comes back with nonlinear distortions on every excited line, the same in every period
    (Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed., Wiley 2012, Ch. 3),
    so they are not in any period-to-period noise, and the referral ``H_rec H_model / H_replay`` carries them
    into the data, largest relative to the response where it is small (between and above the resonances).
    Whether the recorded structure shares them is not known. So the force is replayed again at
    :data:`~vlab.diagnose.data.replay.LOW_LEVEL` x its level -- the plant's best linear approximation -- and
    the squared relative difference (:func:`~vlab.diagnose.data.replay.distortion_variance`) is the
    replay's own relative variance per line, propagated as the referral propagates a baseline's noise
    (:func:`~vlab.diagnose.data.measured.refer_to_model`); the validation judges its reruns with the same
    variance (:mod:`vlab.diagnose.validate`), so the mismatch test, the selection and the validation
    weigh the plant's level dependence alike.

    Parameters
    ----------
    data : FrfData
        Referred through the replay on ``plant`` (``h_baseline`` the replay's FRFs), with its recording.
    nominal, plant, guard_s
        As for :func:`referred_through_replay`.

    Returns
    -------
    data : FrfData
        ``var`` and ``var_baseline`` with the distortion's variance added [((m/s)/N)^2], ``var_distortion``
        that relative variance [1].
    largest : float
        The largest relative distortion over the lines and channels [1].
    low : Recording
        The replay at :data:`~vlab.diagnose.data.replay.LOW_LEVEL` x the level (the validation's nominal rerun
        at that level, :mod:`vlab.diagnose.validate`).

    Raises
    ------
    OptionError
        ``data`` not referred through a replay of its recording (no ``h_baseline`` or no recording).
    ModelError, SimulationError
        As :func:`replay_reference`.
    """
    from .replay import LOW_LEVEL, distortion_variance

    if data.h_baseline is None or data.recording is None:
        raise OptionError("the replay's level dependence needs data referred through a replay of its recording")
    low, low_rec, _kind = replay_reference(data, nominal, plant, guard_s=guard_s, level=LOW_LEVEL)
    rel = distortion_variance((data.h_baseline,), (low.h,))
    return with_level_dependence(data, rel, on_baseline=True), float(np.sqrt(rel.max())), low_rec


def with_level_dependence(data: FrfData, rel: np.ndarray, *, on_baseline: bool) -> FrfData:
    """``data`` with a plant's level dependence, the relative variance ``rel`` per line
    (:func:`~vlab.diagnose.data.replay.distortion_variance`), added to its variance (module notes of
    :func:`with_replay_distortion`).

    Parameters
    ----------
    data : FrfData
        FRFs ``h`` [(m/s)/N], shape (n_f, n_o).
    rel : ndarray, shape (n_f, n_o)
        Relative complex variance [1].
    on_baseline : bool
        True: the variance is the replay's, the baseline the data were referred through (``var_baseline`` gets
        it too and ``var_distortion`` is set: the validation's reruns on that plant carry it,
        :mod:`vlab.diagnose.validate`); False: it is the recording's own, unknown level dependence, referred
        through a replay that has none (a linear one): only ``var`` gets it.

    Returns
    -------
    FrfData
        ``var`` + ``rel |h|^2`` [((m/s)/N)^2] (and, on the baseline, ``var_baseline`` + ``rel |h_baseline|^2``).

    Raises
    ------
    ValueError
        ``rel`` not of the shape of ``data.h``, or ``on_baseline`` without ``data.h_baseline``.
    """
    rel = np.asarray(rel, dtype=float)
    if rel.shape != data.h.shape:
        raise ValueError(f"level dependence of shape {rel.shape} for FRFs of shape {data.h.shape}")
    if not on_baseline:
        return replace(data, var=data.var + rel * np.abs(data.h) ** 2)
    if data.h_baseline is None:
        raise ValueError("a level dependence on the baseline needs data referred through a baseline")
    var_base = (data.var_baseline if data.var_baseline is not None else 0.0) + rel * np.abs(data.h_baseline) ** 2
    return replace(data, var=data.var + rel * np.abs(data.h) ** 2, var_baseline=var_base, var_distortion=rel)
