"""The modal test of each structure and the settings of one experiment (Sec. 5.3, 5.4).

:data:`TESTS` holds the shipped structures' modal tests (band, resolution,
force level, points; Sec. 5.4.2, Tables 10 and 19-21) and
:func:`test_definition` picks a structure's own ``[test]`` table or the
shipped one. :class:`ExperimentConfig` gathers the options of ``vlab
experiment``; :func:`default_chain` is the hardware chain of Sec. 5.3 at the
thesis's sampling period for a controller, :func:`with_hardware` that chain with
a structure file's ``[hardware]`` settings.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import SpecError
from ..fe import FEModel
from ..lab.blocks import PC1000_DELAY_PERIODS, RC_CORNER_HZ
from ..lab.loop import HardwareChain
from ..spec import StructureSpec, StructureTest, load_spec

EXCITATIONS = ("random", "sweep", "impulse")


TESTS = {
    # BCC: 0-25 Hz random at point 9, displacement at point 6 (Sec. 5.4.2, Table 10)
    "bcc": StructureTest((0.5, 25.0), 0.05, 0.5, 6, 6, (5, 6, 7, 9), "displacement"),
    # grid: 0-10 Hz random at joint 4, velocity at joints 1-5, 8 (Sec. 5.4.2, Tables 19-21)
    "grid": StructureTest((0.2, 10.0), 0.02, 0.2, 4, 4, (1, 2, 3, 4, 5, 8), "velocity"),
}


def test_definition(spec: StructureSpec | str) -> StructureTest:
    """The modal test of a structure (Sec. 5.4): its own ``[test]`` table, else the shipped one.

    A structure file's ``[test]`` table (band, resolution, force level,
    points, response quantity; read by :func:`vlab.spec.load_spec`) wins;
    without one, a structure named like a shipped one (``"bcc"``, ``"grid"``)
    gets its entry of :data:`TESTS` (Sec. 5.4.2, Tables 10 and 19-21).

    Parameters
    ----------
    spec : StructureSpec or str
        The structure, or a name or TOML path for :func:`vlab.spec.load_spec`.

    Returns
    -------
    StructureTest

    Raises
    ------
    SpecError
        The structure has no ``[test]`` table and no shipped test (the
        message names its file and the fields to add); as :func:`load_spec`
        for a name or path.
    """
    if isinstance(spec, (str, Path)):
        spec = load_spec(spec)
    if spec.test is not None:
        return spec.test
    if spec.name in TESTS:
        return TESTS[spec.name]
    raise SpecError(f"{spec._file()}: structure {spec.name!r} has no [test] table (band_hz, resolution_hz, rms_n, "
                    f"n_modes, response_point, measured_points, response_quantity) and no shipped test "
                    f"(shipped: {', '.join(TESTS)}); add one (`vlab init beam PATH` writes an example)")


test_definition.__test__ = False  # not a pytest test, although its name starts with "test_"



@dataclass(frozen=True)
class ExperimentConfig:
    """Settings of one experiment (the options of ``vlab experiment``).

    Attributes
    ----------
    structure : str
        Structure name (``"bcc"``, ``"grid"`` or the ``name`` of a structure file); the
        test itself comes from the FE model's spec (:func:`test_definition`).
    controller : str
        ``"none"`` (open loop), ``"lqg"``, ``"mfdrf"``, ``"lqdrf"`` or
        ``"lqdrf-diag"`` (:data:`vlab.design.CONTROLLERS`; ``"lqr"`` is refused:
        it needs the full state).
    reduction : str or None
        Design model (``"full"``, ``"exact"``, ``"guyan"``,
        ``"corrected-guyan"``); None = the thesis's choice
        (:func:`vlab.design.design_controller`).
    excitation : str
        One of :data:`EXCITATIONS`: ``"random"`` (periodic pseudo-random),
        ``"sweep"`` (a linear sweep across the band once per record) or
        ``"impulse"`` (one half-sine pulse per record), in the structure's band
        (Sec. 5.4); all three periodic over a record.
    duration_s : float or None
        Run length [s]; None = ``periods`` records of ``1 / resolution_hz``.
    periods : int
        Number of records of length ``1 / resolution_hz`` [s] run when
        ``duration_s`` is None: ``periods - 1`` records are measured after the
        settling records (one, or more for lightly damped modes; see
        :func:`~vlab.experiment.settling.settle_records`).
    chain : HardwareChain or None
        Hardware between controller and coils (Sec. 5.3). None (default) =
        the thesis chain at the thesis's sampling period for ``controller``
        (:func:`vlab.design.thesis_period_s`: LQG 1 ms, the others 0.5 ms);
        after construction it is always a :class:`~vlab.lab.loop.HardwareChain`.
    seed : int
        Seed of the excitation, the sensor noise and the DRF optimisers' multi-start.
    plant : str
        ``"mujoco"`` (MuJoCo plant) or ``"linear"`` (the FE model stepped exactly).
    mjcf : Path or None
        An exported and possibly edited MJCF file to run instead of the plant
        built from the spec (``"mujoco"`` only).
    resolution_hz : float or None
        FRF frequency resolution [Hz]; None = the structure's
        :attr:`StructureTest.resolution_hz`.
    """

    structure: str = "bcc"
    controller: str = "mfdrf"
    reduction: str | None = None
    excitation: str = "random"
    duration_s: float | None = None
    periods: int = 3
    chain: HardwareChain | None = None
    seed: int = 0
    plant: str = "mujoco"
    mjcf: Path | None = None
    resolution_hz: float | None = None

    def __post_init__(self) -> None:
        if self.chain is None:
            object.__setattr__(self, "chain", default_chain(self.controller))


def default_chain(
    controller: str,
    *,
    period_s: float | None = None,
    delay_periods: float = PC1000_DELAY_PERIODS,
    filter_hz: float | None = RC_CORNER_HZ,
    amplifier_gain: float = 1.0,
    amplifier_limit_n: float | None = None,
    noise_m_s: float = 0.0,
    actuator_gain: dict[int, float] | None = None,
    sensor_gain: dict[int, float] | None = None,
    actuator_lag_hz: float | None = None,
    sensor_lag_hz: float | None = None,
    channel_delay_periods: dict[int, float] | None = None,
    channel_actuator_lag_hz: dict[int, float | None] | None = None,
    channel_sensor_lag_hz: dict[int, float | None] | None = None,
    channel_limit_n: dict[int, float | None] | None = None,
) -> HardwareChain:
    """The Sec. 5.3 hardware chain at the thesis's sampling period for ``controller``.

    Parameters
    ----------
    controller : str
        ``"none"`` or one of :data:`vlab.design.CONTROLLERS`; selects the
        period (:func:`vlab.design.thesis_period_s`: LQG 1 ms, others 0.5 ms).
    period_s : float, optional
        Controller sampling period [s]; None = the thesis period for ``controller``.
    delay_periods, filter_hz, amplifier_gain, amplifier_limit_n, noise_m_s : float or None
        As the fields of :class:`~vlab.lab.loop.HardwareChain` (delay in periods, RC corner [Hz],
        amplifier gain [N/N] and limit [N], sensor noise RMS [m/s]); defaults the thesis chain.
    actuator_gain, sensor_gain : dict, optional
        Per-channel gain errors, as :class:`~vlab.lab.loop.HardwareChain`; None = none.
    actuator_lag_hz, sensor_lag_hz : float, optional
        First-order actuator and sensor lags [Hz], as :class:`~vlab.lab.loop.HardwareChain`; None = none.
    channel_delay_periods, channel_actuator_lag_hz, channel_sensor_lag_hz, channel_limit_n : dict, optional
        Per-channel delay [periods], lags [Hz] and force limit [N], as
        :class:`~vlab.lab.loop.HardwareChain`; None = none.

    Returns
    -------
    HardwareChain

    Raises
    ------
    TypeError
        A setting that is not a :class:`~vlab.lab.loop.HardwareChain` field.
    ModelError
        Unknown controller; a setting :class:`~vlab.lab.loop.HardwareChain` refuses.
    """
    from ..design import thesis_period_s

    thesis_s = thesis_period_s(controller)  # also refuses an unknown controller
    return HardwareChain(
        period_s=thesis_s if period_s is None else period_s,
        delay_periods=delay_periods, filter_hz=filter_hz, amplifier_gain=amplifier_gain,
        amplifier_limit_n=amplifier_limit_n, noise_m_s=noise_m_s, actuator_gain=dict(actuator_gain or {}),
        sensor_gain=dict(sensor_gain or {}), actuator_lag_hz=actuator_lag_hz, sensor_lag_hz=sensor_lag_hz,
        channel_delay_periods=dict(channel_delay_periods or {}),
        channel_actuator_lag_hz=dict(channel_actuator_lag_hz or {}),
        channel_sensor_lag_hz=dict(channel_sensor_lag_hz or {}), channel_limit_n=dict(channel_limit_n or {}),
    )


def with_hardware(chain: HardwareChain, spec: StructureSpec) -> HardwareChain:
    """``chain`` with the hardware-chain settings of the structure file's ``[hardware]`` table.

    The table's sensor gains, per-channel delays (converted to periods of ``chain.period_s``) and
    actuator and sensor lags (:mod:`vlab.spec.hardware`) fill the chain's per-channel entries; an entry
    the chain already has for a channel (set on the command line or by a diagnosis hypothesis) is kept.
    Applying it twice changes nothing. The table's actuator gains are not put into the chain: they live in
    the plant (the FE input matrix and the MuJoCo coils' ``gainprm``), where an MJCF plant carries its own.

    Parameters
    ----------
    chain : HardwareChain
        The run's chain (Sec. 5.3).
    spec : StructureSpec
        The structure; without a ``[hardware]`` table ``chain`` is returned as it is.

    Returns
    -------
    HardwareChain

    Raises
    ------
    ModelError
        A setting :class:`~vlab.lab.loop.HardwareChain` refuses.
    """
    hw = getattr(spec, "hardware", None)
    if hw is None or not hw.chain_settings:
        return chain
    delays = {p: d / chain.period_s for p, d in hw.delay_s.items()}
    return replace(chain, sensor_gain={**hw.sensor_gain, **chain.sensor_gain},
                   channel_delay_periods={**delays, **chain.channel_delay_periods},
                   channel_actuator_lag_hz={**hw.actuator_lag_hz, **chain.channel_actuator_lag_hz},
                   channel_sensor_lag_hz={**hw.sensor_lag_hz, **chain.channel_sensor_lag_hz})


def dissertation_structure(structure) -> bool:
    """Whether ``structure`` is one of the dissertation's (the BCC or the grid), whose tables are compared.

    Reports give a dissertation structure's numbers also in the thesis's units (in, lbf, cs) and name the
    thesis's values and sections; any other structure gets SI and vlab's defaults only.

    Parameters
    ----------
    structure : str or StructureSpec
        A name (``"bcc"``, ``"grid"``), a TOML path, or a spec (its ``name``).

    Returns
    -------
    bool
        True for a name or a spec named like a shipped test (:data:`TESTS`); a path or any other name: False.
    """
    name = getattr(structure, "name", structure)
    return isinstance(name, str) and name in TESTS


def period_source(controller: str, period_s: float, structure=None) -> str:
    """Where a run's sampling period comes from, for reports: the default value or a user setting.

    Parameters
    ----------
    controller : str
        ``"none"`` or one of :data:`vlab.design.CONTROLLERS`.
    period_s : float
        The period used [s].
    structure : str or StructureSpec, optional
        The structure; one that is not the dissertation's (:func:`dissertation_structure`) gets vlab's
        default named without the thesis (default None: the dissertation's wording).

    Returns
    -------
    str
        E.g. ``"thesis value for lqg (Sec. 5.3)"``, ``"set by the user (thesis value for lqg: 1 ms)"``, or for
        a structure of one's own ``"default for lqg"`` / ``"set by the user (default for lqg: 1 ms)"``.

    Raises
    ------
    ModelError
        Unknown controller.
    """
    from ..design import thesis_period_s

    ref = thesis_period_s(controller)
    own = structure is not None and not dissertation_structure(structure)
    name = "the open loop" if own and controller == "none" else controller
    if abs(period_s - ref) <= 1e-12 * ref:
        return f"default for {name}" if own else f"thesis value for {controller} (Sec. 5.3)"
    return f"set by the user ({'default' if own else 'thesis value'} for {name}: {ref * 1e3:g} ms)"


def test_of(fe: FEModel) -> tuple[StructureTest, tuple[int, ...], int]:
    """The structure's test, its actuator points (channel order) and its excitation point.

    Parameters
    ----------
    fe : FEModel
        The FE model; its spec gives the test and the instrumentation.

    Returns
    -------
    (StructureTest, tuple of int, int)
        :func:`test_definition`, the actuator point ids and the excitation point id.

    Raises
    ------
    SpecError
        Structure without a test definition.
    """
    return test_definition(fe.spec), tuple(fe.spec.instrumentation.actuators), fe.spec.instrumentation.excitation
