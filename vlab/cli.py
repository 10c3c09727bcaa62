"""The ``vlab`` command line.

Thin: every command parses its options, calls the library and prints a rich
table or, with ``--json``, one JSON object with stable keys (README lists
them).

One error path for every command: a failure is printed as one line
``error: <message>`` on stderr naming the file, field, option or value (escaped
so that rich markup never eats a value such as ``[0.0]``), with no traceback
unless the global ``--debug`` option is given. Exit status:

- 0: success;
- 1: a failed run: :class:`~vlab.errors.SimulationError` (the plant diverged),
  :class:`~vlab.errors.MeasurementError` during a run, a run whose own warning
  calls the comparison not meaningful, an operating-system error while
  writing (disk full, ...), or an internal error;
- 2: bad input, refused before any work starts: a bad option (Click's usage
  errors, :class:`~vlab.errors.OptionError`), an output path that cannot be
  written as asked (:class:`~vlab.errors.OutputError`: exists without
  ``--overwrite``, missing parent folder, empty), a run too large for the
  machine (:class:`~vlab.errors.ResourceError`), a bad spec, data file or
  model (:class:`~vlab.errors.SpecError`, :class:`~vlab.errors.DataFileError`,
  :class:`~vlab.errors.ModelError`, :class:`~vlab.errors.ReductionError`; the
  classes of :data:`vlab.errors.BAD_INPUT_ERRORS`), and for ``diagnose`` a
  recording that cannot be analysed (:class:`~vlab.errors.MeasurementError`);
- 130: interrupted (Ctrl-C); nothing is written (or the message says what was kept).

Every command that writes (experiment, reproduce, diagnose, export-mjcf)
writes atomically (:mod:`vlab.io.atomic`): into a temporary folder or file
beside the target, moved into place when complete; an existing non-empty
folder or an existing file is replaced only with ``--overwrite``, and a folder
only when its manifest proves every file in it vlab's (:mod:`vlab.io.manifest`);
a second run writing the same folder at the same time is refused at once; parent
folders are not created (except those of a command's default ``out/...``).
"""

from __future__ import annotations

import json
import math
import os
import sys
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from typer.core import TyperCommand, TyperGroup
from typer.exceptions import Abort, Exit, TyperException

from .errors import BAD_INPUT_ERRORS, MeasurementError, OptionError, ResourceError, VlabError

EPILOG = ("Exit status: 0 success; 1 failed run (simulation diverged, measurement failed during a run, "
          "not-meaningful comparison, write error); 2 bad input (option, output path, spec, data file, model, "
          "run too large for the machine), refused before any work starts; 130 interrupted (nothing written). "
          "Errors are one line without traceback; --debug shows the traceback.")

_STATE: dict[str, Any] = {"debug": False, "interrupted": "interrupted: nothing written"}

#: Width of stdout's console when it is not a terminal (piped, redirected, captured) and COLUMNS is not set:
#: wide enough that no table cell is cut and no row wraps (a line is as long as its content).
PIPED_WIDTH = 10_000


class _StdoutConsole(Console):
    """Console of stdout: the terminal's width on a terminal; when piped, :data:`PIPED_WIDTH` (no cut cells)."""

    @property
    def size(self):
        from rich.console import ConsoleDimensions

        dims = super().size
        columns = self._environ.get("COLUMNS")
        if self._width is None and not self.is_terminal and not (columns and columns.isdigit()):
            return ConsoleDimensions(PIPED_WIDTH, dims.height)
        return dims

    @size.setter
    def size(self, new_size) -> None:
        Console.size.fset(self, new_size)


console = _StdoutConsole()
err_console = Console(stderr=True)


def _error_line(text: str) -> None:
    err_console.print(f"[bold red]error:[/] {escape(text)}", soft_wrap=True, highlight=False)


def _exit_code(exc: BaseException, command: str | None) -> int:
    """Exit status of an exception (the mapping in the module docstring)."""
    if isinstance(exc, BAD_INPUT_ERRORS):
        return 2
    if isinstance(exc, MeasurementError) and command == "diagnose":
        return 2  # the recording given is the input
    if isinstance(exc, VlabError):
        return 1
    if isinstance(exc, UnicodeDecodeError):  # a file given that is not text
        return 2
    return 1  # an internal error (a plain ValueError or TypeError from deep in a run included)


def _untyped_help_option(option):
    """``--help`` shown without a type in the help (it takes no value: not ``<bool>``)."""
    if option is not None:
        option.metavar = ""
    return option


class _VlabCommand(TyperCommand):
    """A command whose ``--help`` option is shown without a type."""

    def get_help_option(self, ctx):
        return _untyped_help_option(super().get_help_option(ctx))


class _VlabGroup(TyperGroup):
    """The app's group: turns every exception of a command into one error line and an exit status."""

    def get_help_option(self, ctx):
        return _untyped_help_option(super().get_help_option(ctx))

    def invoke(self, ctx) -> Any:
        _STATE["debug"] = False  # set by the callback (--debug)
        _STATE["interrupted"] = "interrupted: nothing written"
        _STATE["out_path"] = _STATE["out_id"] = None
        _STATE["sigint"] = False
        from .io.confine import ALLOW_ENV

        allow_env = os.environ.get(ALLOW_ENV)
        restore = _install_sigint_flag()
        try:
            return super().invoke(ctx)
        except (Exit, Abort, TyperException):  # exits, usage errors: typer's own handling
            raise
        except KeyboardInterrupt:
            if _STATE["debug"]:
                raise
            _interrupted()
        except Exception as exc:  # noqa: BLE001 - the single error path of the CLI
            if _STATE["debug"]:
                raise
            if _STATE["sigint"]:  # a library turned the KeyboardInterrupt into its own error (pyuff does)
                _interrupted()
            command = ctx.invoked_subcommand
            if isinstance(exc, (VlabError, OSError, UnicodeDecodeError)):
                text = str(exc) or type(exc).__name__
                if isinstance(exc, OSError) and not isinstance(exc, VlabError):
                    text = f"{str(exc.filename) + ': ' if exc.filename else ''}{exc.strerror or exc}"
            elif isinstance(exc, MemoryError):
                text = f"out of memory ({exc}); shorten the run or free memory"
            else:
                text = (f"internal error {type(exc).__name__}: {exc} (run `vlab --debug {command or ''} ...` for "
                        "the traceback and report it)")
            _error_line(text)
            raise Exit(_exit_code(exc, command)) from None
        finally:
            restore()
            from .io.manifest import release_lock

            release_lock()  # the output folder's lock, when the command ended before writing it
            if allow_env is None:
                os.environ.pop(ALLOW_ENV, None)
            else:
                os.environ[ALLOW_ENV] = allow_env


def _expect_output(out_path: Path) -> None:
    """Remember the output folder (and the identity of what is there now) for the message of an interrupt."""
    _STATE["interrupted"] = f"interrupted: nothing written ({out_path} unchanged)"
    _STATE["out_path"] = out_path
    _STATE["out_id"] = _folder_id(out_path)


def _folder_id(path: Path) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


def _interrupted() -> None:
    text = _STATE["interrupted"]
    out_path = _STATE.get("out_path")
    if out_path is not None and _folder_id(out_path) != _STATE.get("out_id"):
        # the new folder was renamed into place before the interrupt landed (the rename is atomic)
        text = f"interrupted after the outputs were written to {out_path}"
    err_console.print(escape(text), soft_wrap=True, highlight=False)
    raise Exit(130) from None


def _install_sigint_flag():
    """While a command runs, Ctrl-C also sets ``_STATE["sigint"]`` (a library may swallow the KeyboardInterrupt).

    Only where SIGINT has Python's default handler (not ignored, not replaced) and on the main thread.
    Returns the function restoring the previous handler.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.default_int_handler:
        return lambda: None

    def on_sigint(signum, frame):
        _STATE["sigint"] = True
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, on_sigint)
    return lambda: signal.signal(signal.SIGINT, previous)


STRUCTURE_HELP = ("structure: bcc (Beam Cross-Cable), grid (Hanging Grid) or the path of a .toml structure file "
                  "(`vlab init` writes one)")
STRUCTURE_METAVAR = "<bcc|grid|FILE.toml>"  # the type shown for --structure (diagnose)
REDUCTION_HELP = ("design model: full FE model, exact reduction, Guyan reduction or Guyan corrected with measured "
                  "modes (default: the thesis's choice: DRF on the full model for the BCC, "
                  "everything else on the structure's default reduction)")


def _opt(default: Any, *decls: str, help: str, **kwargs: Any) -> Any:
    """``typer.Option`` whose help is plain text: brackets such as ``[s]`` are escaped, not read as rich markup."""
    return typer.Option(default, *decls, help=escape(help), **kwargs)


def _flag(*decls: str, help: str) -> Any:
    """An on/off option: off by default, shown without a type (no ``<bool>``) in ``--help``."""
    return typer.Option(False, *decls, help=escape(help) + " (a flag; default: off)", metavar="",
                        show_default=False)


def _arg_structure() -> Any:
    return typer.Argument(..., help=STRUCTURE_HELP, show_default=False)


def _format_opt() -> Any:
    return _opt(OutputFormat.table, "--format",
                help="output: a rich table (full width when piped), CSV (a header of column names with units, "
                     "one line per row) or one JSON object (keys with units)")


def _output_format(fmt: "OutputFormat", as_json: bool) -> str:
    """The output format of ``--format`` and the older ``--json`` (= ``--format json``); OptionError if they clash."""
    if as_json and fmt not in (OutputFormat.table, OutputFormat.json):
        raise OptionError(f"--json contradicts --format {fmt.value}: give one of the two")
    return "json" if as_json else fmt.value


def _load_structure(value: str):
    """The spec of a structure argument: a shipped name or a ``.toml`` path (SpecError naming the file: exit 2)."""
    from .spec import load_spec

    if str(value).strip() == "":
        raise OptionError("structure: an empty name; give bcc, grid or the path of a .toml file")
    spec = load_spec(value)
    fixed_w = {sup.point for sup in spec.supports if "w" in sup.fixed}
    if spec.points and fixed_w >= set(spec.points):
        from .errors import SpecError

        raise SpecError(f"{spec.path or value}: field 'supports': every point ({len(spec.points)}) is fixed out of "
                        "plane ('w' in fixed): nothing can vibrate; leave at least one point free")
    return spec


def _fe_model_of(spec):
    """The checked FE model of ``spec``: cached for a shipped structure file, built afresh for any other file."""
    from .fe import build_fe_model
    from .models import check_fe_model, nominal_fe_model
    from .spec import STRUCTURES_DIR

    if spec.path is not None and spec.path.resolve() == (STRUCTURES_DIR / f"{spec.name}.toml").resolve():
        return nominal_fe_model(spec.name)
    return check_fe_model(build_fe_model(spec))


def _print_rows(fmt: str, rows: list[dict], columns, title: str | None = None) -> None:
    """``rows`` as a rich table on stdout (``fmt == "table"``) or as CSV (``"csv"``)."""
    from .io.tabular import rich_table, write_csv

    if fmt == "csv":
        write_csv(rows, columns, sys.stdout)
    else:
        console.print(rich_table(rows, columns, title=title))


app = typer.Typer(
    cls=_VlabGroup,
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="vlab: a virtual laboratory for active vibration control of flexible structures.",
    epilog=EPILOG,
)


@app.callback(epilog=EPILOG)
def _root(debug: bool = _flag("--debug", help="show the Python traceback of an error"),
          allow_outside_inputs: bool = _flag(
              "--allow-outside-inputs", help="read files that a structure file ([reference]) or an MJCF model "
                                             "(<include>, assets) names outside its own folder (default: refused)"),
          ) -> None:
    """vlab: a virtual laboratory for active vibration control of flexible structures."""
    from .io.confine import ALLOW_ENV

    _STATE["debug"] = debug
    if allow_outside_inputs:
        os.environ[ALLOW_ENV] = "1"  # read by the loaders, here and in worker processes; restored after the command


class OutputFormat(str, Enum):
    table = "table"
    csv = "csv"
    json = "json"


class Reduction(str, Enum):
    full = "full"
    exact = "exact"
    guyan = "guyan"


def _print_json(obj: dict[str, Any]) -> None:
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    sys.stdout.write(json.dumps(obj, default=default, indent=2) + "\n")


def _pad(values: np.ndarray, n: int) -> list[float | None]:
    out: list[float | None] = [float(v) for v in values[:n]]
    return out + [None] * (n - len(out))


@app.command(cls=_VlabCommand)
def modes(
    structure: str = _arg_structure(),
    reduction: Reduction = _opt(Reduction.full, "--reduction",
                                help="model: the full FE model, its exact reduction or Guyan reduction"),
    n: int = _opt(12, "--n", min=1, help="number of modes listed, >= 1 (at most the model's degrees of freedom)"),
    fmt: OutputFormat = _format_opt(),
    as_json: bool = _flag("--json", help="print one JSON object instead of the table (= --format json)"),
) -> None:
    """Natural frequencies, against the dissertation's Table 1 (BCC) or Table 3 (grid) where the structure has one."""
    from .fe import modal_analysis
    from .io.tabular import Column
    from .models import reduce_model
    from .reference import column

    out = _output_format(fmt, as_json)
    spec = _load_structure(structure)
    fe = _fe_model_of(spec)
    if n > fe.m.shape[0]:
        raise OptionError(f"--n {n} exceeds the model's {fe.m.shape[0]} degrees of freedom")
    if reduction is Reduction.full:
        f = modal_analysis(fe.m, fe.k, n).frequencies_hz
    else:
        red = reduce_model(fe, reduction.value)
        f = red.natural_frequencies_hz()[:n]
    table = spec.reference.get("frequencies")
    ref_a = column(table, "analytical_hz") if table else np.zeros(0)
    ref_e = column(table, "experimental_hz") if table else np.zeros(0)
    n_shown = len(f)
    if out == "json":
        _print_json(
            {
                "structure": spec.name,
                "reduction": reduction.value,
                "frequencies_hz": f,
                "reference_analytical_hz": _pad(ref_a, n_shown),
                "reference_experimental_hz": _pad(ref_e, n_shown),
                "reference_table": table,
            }
        )
        return
    rows = []
    for i in range(n_shown):
        row = {"mode": i + 1, "frequency_hz": float(f[i])}
        for key, ref in (("analytical", ref_a), ("experimental", ref_e)):
            if i < len(ref):
                row[f"thesis_{key}_hz"] = float(ref[i])
                row[f"error_{key}_pct"] = 100 * (f[i] / ref[i] - 1)
        rows.append(row)
    cols = [Column("mode", "mode"), Column("frequency_hz", "vlab [Hz]", ".3f")]
    if table:
        cols += [Column("thesis_analytical_hz", "thesis analytical [Hz]", ".3f"),
                 Column("error_analytical_pct", "error [%]", "+.2f"),
                 Column("thesis_experimental_hz", "thesis experimental [Hz]", ".3f"),
                 Column("error_experimental_pct", "error [%]", "+.2f")]
    title = f"{spec.title}: natural frequencies ({reduction.value} model)" + (f" vs {table}" if table else "")
    _print_rows(out, rows, cols, title)


class ControllerName(str, Enum):
    lqr = "lqr"
    lqg = "lqg"
    mfdrf = "mfdrf"
    lqdrf = "lqdrf"
    lqdrf_diag = "lqdrf-diag"


class DesignReduction(str, Enum):
    full = "full"
    exact = "exact"
    guyan = "guyan"
    corrected_guyan = "corrected-guyan"


@app.command(cls=_VlabCommand)
def design(
    structure: str = _arg_structure(),
    controller: ControllerName = _opt(ControllerName.mfdrf, "--controller",
                                      help="controller: LQR (full state), LQG, MFDRF, LQDRF or LQDRF with a "
                                           "diagonal gain"),
    reduction: DesignReduction = _opt(None, "--reduction", help=REDUCTION_HELP),
    modes_file: str = _opt(None, "--modes", help="UFF 55 file of measured modes, read only with --reduction "
                                                  "corrected-guyan (default: a virtual modal test of the MuJoCo plant)"),
    seed: int = _opt(0, "--seed", help="seed of the optimiser's multi-start, an integer in [0, 2**32)"),
    period_ms: float = _opt(None, "--period-ms",
                            help="sampling period of the realization [ms], > 0 (default: the thesis's, "
                                 "Sec. 5.3: LQG 1 ms, the others 0.5 ms)"),
    fmt: OutputFormat = _format_opt(),
    as_json: bool = _flag("--json", help="print one JSON object instead of the tables (= --format json)"),
) -> None:
    """Design a controller with the dissertation's settings; print gains, damping and performance."""
    from .design import design_controller
    from .experiment.results import design_summary
    from .io.tabular import Column
    from .experiment.config import period_source

    out = _output_format(fmt, as_json)
    period_s = _period_s(period_ms)
    _seed(seed)
    if modes_file is not None and reduction is not DesignReduction.corrected_guyan:
        raise OptionError("--modes is read only with --reduction corrected-guyan "
                          f"(got --reduction {reduction.value if reduction else 'default'})")
    _input_file("--modes", modes_file)
    spec = _load_structure(structure)
    fe = _fe_model_of(spec)
    measured = _measured_modes(fe, modes_file) if reduction is DesignReduction.corrected_guyan else None
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=err_console,
                  transient=True, disable=out != "table") as bar:
        bar.add_task(f"designing {controller.value} for {spec.name}", total=None)
        d = design_controller(fe, controller.value, model=reduction.value if reduction else None,
                              measured_modes=measured, seed=seed, period_s=period_s)
    if out == "json":
        _print_json({**design_summary(d), "period_source": period_source(d.controller, d.period_s)})
        return
    n_rows = min(max(len(d.performance_index), 6), len(d.damping_ratios))
    rows = [{"mode": i + 1, "frequency_hz": float(d.frequencies_hz[i]), "damping_ratio": float(d.damping_ratios[i]),
             "performance_index_thesis_units": float(d.performance_index[i]) if i < len(d.performance_index) else None}
            for i in range(n_rows)]
    cols = [Column("mode", "mode"), Column("frequency_hz", "f [Hz]", ".3f"),
            Column("damping_ratio", "zeta [-]", ".4f"),
            Column("performance_index_thesis_units", "J (modal IC) [thesis units]", ".4g")]
    if out == "csv":
        _print_rows(out, rows, cols)
        return
    console.print(f"[bold]{escape(spec.name)} {d.controller}[/] on the {d.model} model — converged: {d.converged} "
                  f"({escape(str(d.message))})")
    console.print(f"sampling period {d.period_s * 1e3:g} ms ({period_source(d.controller, d.period_s)})")
    if d.gamma is not None:
        console.print(f"gamma = {d.gamma:.4f} lb*s/in" + (f", beta = {d.beta:.4g}" if d.beta is not None else ""))
    g = d.extra.get("gain_thesis_lb_s_per_in")
    if g is not None:
        console.print("D in lb*s/in (thesis units, the form of Tables 7, 11, 15):")
        console.print(np.array2string(np.asarray(g), precision=4, suppress_small=True))
    _print_rows(out, rows, cols, "closed loop on the design model")


class ExpController(str, Enum):
    """Controllers an experiment can run (LQR is not offered: it needs every state measured)."""

    none = "none"
    lqg = "lqg"
    mfdrf = "mfdrf"
    lqdrf = "lqdrf"
    lqdrf_diag = "lqdrf-diag"


class Excitation(str, Enum):
    random = "random"
    sweep = "sweep"
    impulse = "impulse"


class PlantKind(str, Enum):
    mujoco = "mujoco"
    linear = "linear"


EXPERIMENT_OUT = "out/experiment"


@app.command(cls=_VlabCommand)
def experiment(
    structure: str = typer.Argument("bcc", help=STRUCTURE_HELP),
    controller: ExpController = _opt(ExpController.mfdrf, "--controller",
                                     help="controller in the loop: none (open loop), LQG, MFDRF, LQDRF or LQDRF "
                                          "with a diagonal gain (LQR needs the full state: run it as LQG)"),
    reduction: DesignReduction = _opt(None, "--reduction", help=REDUCTION_HELP + "; not with --controller none"),
    excitation: Excitation = _opt(Excitation.random, "--excitation",
                                  help="force at the excitation point, periodic over one record in the structure's "
                                       "band (Sec. 5.4): pseudo-random, linear sweep or half-sine impulse"),
    duration: float = _opt(
        None, "--duration", help="run length [s], at least 2 records of 1/resolution (BCC: 2 x 20 s = 40 s; "
                                 "grid: 2 x 50 s = 100 s) (default: the records the slowest mode needs to settle "
                                 "+ 2 measured)"),
    delay_samples: float = _opt(1.35, "--delay-samples",
                                help="computation delay [sampling periods], >= 0 (Sec. 5.3)"),
    period_ms: float = _opt(None, "--period-ms",
                            help="controller sampling period [ms], > 0 (default: the thesis's for the "
                                 "controller, Sec. 5.3: LQG 1 ms, the others 0.5 ms)"),
    noise: float = _opt(1e-6, "--noise", help="velocity-sensor noise standard deviation [m/s], >= 0 (0 = off)"),
    seed: int = _opt(0, "--seed", help="seed of the excitation, the sensor noise and the design's multi-start, "
                                       "an integer in [0, 2**32)"),
    mjcf: str = _opt(None, "--mjcf", help="MJCF file exported by `vlab export-mjcf` (and edited) to run instead "
                                          "of the built plant; needs --plant mujoco (default: none)"),
    plant: PlantKind = _opt(PlantKind.mujoco, "--plant",
                            help="plant: the MuJoCo model or the linear FE model stepped exactly (fast)"),
    out: str = _opt(EXPERIMENT_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = _flag("--overwrite", help="replace an existing non-empty output folder"),
    spawn: bool = _flag("--spawn", help="open the rerun viewer live (needs a display)"),
    fmt: OutputFormat = _format_opt(),
    as_json: bool = _flag("--json", help="print results.json to stdout instead of the table (= --format json)"),
    allow_unstable: bool = _flag("--allow-unstable",
                                 help="exit 0 even when the comparison is not meaningful: a warning says so, "
                                      "the loop is predicted unstable or the delay is at least one record"),
) -> None:
    """Run a closed-loop experiment (DRF at 2 kHz, LQG at 1 kHz as Sec. 5.3), measure it like a modal test.

    Every option is checked before the run starts; the run's memory and time are estimated and a run that
    does not fit in the available memory is refused. The outputs are written atomically; a run whose own
    warning calls the comparison not meaningful (self-excited oscillation, limit cycle), whose loop the analysis
    predicts unstable (a negative predicted damping ratio) or whose delay is at least one record exits with
    status 1 unless --allow-unstable.
    """

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from .io.atomic import atomic_dir
    from .experiment.results import experiment_summary, failed_premises, write_outputs
    from .io.tabular import Column
    from .experiment.checks import not_meaningful
    from .experiment.config import ExperimentConfig, default_chain, test_definition
    from .experiment.runner import run_experiment

    # --- every option, before any work
    out_fmt = _output_format(fmt, as_json)
    spec = _load_structure(structure)
    out_path = _out_dir(out, EXPERIMENT_OUT, overwrite)
    _number("--noise", noise, low=0.0, what="sensor noise sigma [m/s]")
    _number("--delay-samples", delay_samples, low=0.0, what="computation delay [sampling periods]")
    _number("--duration", duration, low=0.0, low_open=True, what="run length [s]")
    period_s = _period_s(period_ms)
    _seed(seed)
    if reduction is not None and controller is ExpController.none:
        raise OptionError(f"--reduction {reduction.value} has no effect with --controller none (no design)")
    if mjcf is not None:
        if plant is PlantKind.linear:
            raise OptionError(f"--mjcf {mjcf} runs a MuJoCo plant: it contradicts --plant linear")
        _mjcf_input(mjcf)
    if spawn:
        from .viz.rerun_log import viewer_unavailable_reason

        why = viewer_unavailable_reason()
        if why is not None:
            raise OptionError(f"--spawn: the rerun viewer cannot be started here ({why}); run without --spawn "
                              "and open run.rrd with `rerun` where there is a display")
    chain = default_chain(controller.value, delay_periods=delay_samples, noise_m_s=noise,
                          **({} if period_s is None else {"period_s": period_s}))
    test = test_definition(spec)
    if duration is not None and duration < 2.0 / test.resolution_hz - 1e-9:
        raise OptionError(f"--duration {duration:g} s is too short for the {test.resolution_hz:g} Hz resolution: "
                          f"one record of {1 / test.resolution_hz:g} s settles and at least one is measured "
                          f"(>= {2 / test.resolution_hz:g} s)")
    cfg = ExperimentConfig(
        structure=spec.name, controller=controller.value,
        reduction=reduction.value if reduction else None, excitation=excitation.value, duration_s=duration,
        chain=chain, seed=seed, plant=plant.value,
        mjcf=Path(mjcf) if mjcf else None,
    )
    fe = _fe_model_of(spec)
    _guard_experiment(fe, plant=plant.value, period_s=chain.period_s, duration_s=duration,
                      delay_periods=delay_samples, quiet=out_fmt != "table")
    _expect_output(out_path)

    # --- the run
    try:
        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f} %"),
                      TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                      console=err_console, transient=True, disable=out_fmt != "table") as bar:
            task = bar.add_task(f"{spec.name} {controller.value}: simulating", total=1.0)
            result = run_experiment(cfg, fe, progress=lambda x: bar.update(task, completed=x))
    except VlabError as exc:
        partial = getattr(exc, "partial", None)
        if partial is not None:
            from .io.uff import write_recording

            with atomic_dir(out_path, overwrite=overwrite, create_parent=out == EXPERIMENT_OUT) as tmp:
                write_recording(tmp / "recording_partial.uff", partial.recording, overwrite=False)
            err_console.print(f"the recording up to the failure is kept in {escape(str(out_path))}/recording_partial.uff",
                              highlight=False, soft_wrap=True)
        raise
    if out == EXPERIMENT_OUT:
        out_path.absolute().parent.mkdir(parents=True, exist_ok=True)
    files = write_outputs(result, fe.spec, out_path, spawn=spawn, overwrite=overwrite)
    summary = experiment_summary(result)
    premise = failed_premises(result)
    blocking = premise + not_meaningful(result.warnings)
    for w in premise:
        err_console.print(f"[bold yellow]warning:[/] {escape(w)}", soft_wrap=True, highlight=False)

    def _exit_if_not_meaningful() -> None:
        if blocking and not allow_unstable:
            _error_line(f"the comparison is not meaningful ({blocking[0]}); outputs written to "
                        f"{files['results'].parent}/; use --allow-unstable to exit 0")
            raise typer.Exit(code=1)

    for w in files["warnings"]:
        err_console.print(f"[bold yellow]warning:[/] {escape(w)}", soft_wrap=True, highlight=False)
    if out_fmt == "json":
        _print_json(summary)
        _exit_if_not_meaningful()
        return
    rows = [{"mode": m.mode, "frequency_predicted_hz": m.frequency_predicted_hz,
             "frequency_measured_hz": m.frequency_measured_hz, "damping_ratio_predicted": m.damping_predicted,
             "damping_ratio_measured": m.damping_measured, "peak_level_ratio": m.peak_level_ratio}
            for m in result.modes]
    cols = [Column("mode", "mode"), Column("frequency_predicted_hz", "f pred [Hz]", ".3f"),
            Column("frequency_measured_hz", "f meas [Hz]", ".3f"),
            Column("damping_ratio_predicted", "zeta pred [-]", ".4f"),
            Column("damping_ratio_measured", "zeta meas [-]", ".4f"),
            Column("peak_level_ratio", "peak ratio pred/meas [-]", ".3f")]
    if out_fmt == "csv":
        _print_rows(out_fmt, rows, cols)
        for w in result.warnings:
            err_console.print(f"[bold yellow]warning:[/] {escape(w)}", soft_wrap=True, highlight=False)
        _exit_if_not_meaningful()
        return
    _print_rows(out_fmt, rows, cols,
                f"{fe.spec.title}, {controller.value}: analysis vs experiment on the {summary['plant']}")
    console.print(f"analysis: the sampled-data loop (hold, delay, RC filter); sampling period "
                  f"{summary['period_s'] * 1e3:g} ms ({escape(summary['period_source'])})", highlight=False)
    console.print(f"average peak level error: {result.avg_peak_error:.3f}   outputs: "
                  f"{escape(str(files['results'].parent))}/", highlight=False)
    for w in result.warnings:
        err_console.print(f"[bold yellow]warning:[/] {escape(w)}", soft_wrap=True, highlight=False)
    _exit_if_not_meaningful()


#: Largest ``crosscheck --segments`` accepted (the plant's bodies grow linearly with it).
MAX_SEGMENTS = 64


@app.command(cls=_VlabCommand)
def crosscheck(
    structure: str = _arg_structure(),
    segments: int = _opt(None, "--segments", min=1, max=MAX_SEGMENTS,
                         help=f"rigid bodies (hinges) per FE element segment of the MuJoCo plant, 1 to {MAX_SEGMENTS} "
                              "(default: chosen per member)"),
    n: int = _opt(None, "--n", min=1, help="number of modes compared, >= 1 (default: 12 for the grid, 6 "
                                           "otherwise)"),
    fmt: OutputFormat = _format_opt(),
    as_json: bool = _flag("--json", help="print one JSON object instead of the table (= --format json)"),
) -> None:
    """Cross-check the MuJoCo plant against the FE model: frequencies, MAC, free decay.

    Modes are paired one-to-one by MAC over a common band, against the spec's (thesis) mesh and the spec
    meshed at the plant's resolution; MuJoCo modes in the band without an FE partner are listed.
    """
    import math

    from .sim import SimOptions, build_plant
    from .sim import crosscheck as run_crosscheck
    from .sim import free_decay
    from .io.tabular import Column

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    out = _output_format(fmt, as_json)
    spec = _load_structure(structure)
    n_modes = n or (12 if spec.name == "grid" else 6)
    stages = ("building the MuJoCo plant", "pairing with the FE model (thesis mesh)",
              "pairing with the FE model (plant resolution)", "free decay of mode 1")
    with Progress(TextColumn("crosscheck {task.fields[stage]}"), BarColumn(), TimeElapsedColumn(),
                  TextColumn("ETA"), TimeRemainingColumn(), console=err_console, transient=True,
                  disable=out != "table") as bar:
        task = bar.add_task("crosscheck", total=len(stages), stage=stages[0])

        def step(i: int) -> None:
            bar.update(task, completed=i, stage=stages[min(i, len(stages) - 1)])

        plant = build_plant(spec, SimOptions(segments_per_element=segments))
        step(1)
        refs = {"thesis_mesh": run_crosscheck(plant, n_modes)}
        step(2)
        refs["plant_resolution"] = run_crosscheck(plant, n_modes, mesh="plant")
        step(3)
        cc = refs["thesis_mesh"]
        first = cc.pairs[0]
        decay = free_decay(plant, first.sim_mode, sim_modes=cc.sim_modes) if first.sim_mode else None
        step(4)

    def num(x: float) -> float | None:
        return None if x is None or not math.isfinite(x) else float(x)

    verdict, verdict_lines = _crosscheck_tolerance(refs)
    if out == "json":
        _print_json({
            "structure": spec.name,
            "frequencies_hz": {"fe": [p.fe_hz for p in cc.pairs], "mujoco": [num(p.sim_hz) for p in cc.pairs]},
            "relative_error": [num(p.error_pct / 100) for p in cc.pairs],
            "mac": [p.mac for p in cc.pairs],
            "mujoco_mode": [p.sim_mode for p in cc.pairs],
            "references": {key: {
                "fe_elements_per_segment": r.fe_elements,
                "pairing_band_hz": r.band_hz,
                "pairs": [{"fe_mode": p.fe_mode, "fe_hz": p.fe_hz, "mujoco_mode": p.sim_mode,
                           "mujoco_hz": num(p.sim_hz), "error_pct": num(p.error_pct), "mac": p.mac}
                          for p in r.pairs],
                "max_abs_error_pct": num(r.max_error_pct()),
                "min_mac": r.min_mac(),
                "unpaired_mujoco_modes": [{"mujoco_mode": u.sim_mode, "mujoco_hz": u.sim_hz,
                                           "best_fe_mode": u.best_fe_mode, "best_mac": u.best_mac,
                                           "reason": u.reason} for u in r.unpaired],
            } for key, r in refs.items()},
            "free_decay_mode1_hz": None if decay is None else decay.frequency_hz,
            "free_decay_mode1_damping": None if decay is None else decay.damping_ratio,
            "timestep_s": plant.timestep_s,
            **verdict,
        })
        return
    thesis, fine = refs["thesis_mesh"], refs["plant_resolution"]
    rows = []
    for a, b in zip(thesis.pairs, fine.pairs):
        sm = "-" if a.sim_mode is None else str(a.sim_mode)
        if b.sim_mode != a.sim_mode:
            sm += f" / {'-' if b.sim_mode is None else b.sim_mode}"
        rows.append({"fe_mode": a.fe_mode, "mujoco_mode": sm, "mujoco_hz": num(a.sim_hz),
                     "fe_thesis_mesh_hz": a.fe_hz, "error_thesis_mesh_pct": num(a.error_pct),
                     "mac_thesis_mesh": a.mac, "fe_plant_resolution_hz": b.fe_hz,
                     "error_plant_resolution_pct": num(b.error_pct), "mac_plant_resolution": b.mac})
    cols = [Column("fe_mode", "FE mode"), Column("mujoco_mode", "MuJoCo mode"),
            Column("mujoco_hz", "MuJoCo [Hz]", ".4f"), Column("fe_thesis_mesh_hz", "FE [Hz] thesis mesh", ".4f"),
            Column("error_thesis_mesh_pct", "error [%]", "+.2f"), Column("mac_thesis_mesh", "MAC [-]", ".4f"),
            Column("fe_plant_resolution_hz", "FE [Hz] plant resolution", ".4f"),
            Column("error_plant_resolution_pct", "error [%]", "+.2f"),
            Column("mac_plant_resolution", "MAC [-]", ".4f")]
    if out == "csv":
        _print_rows(out, rows, cols)
        return
    _print_rows(out, rows, cols, f"{spec.title}: MuJoCo plant vs FE model (timestep {plant.timestep_s * 1e3:g} ms), "
                                 "modes paired one-to-one by MAC")
    by_count: dict[int, list[str]] = {}
    for k, v in fine.fe_elements.items():
        by_count.setdefault(v, []).append(k)
    els = "; ".join(f"{v} in {', '.join(ks) if len(ks) <= 3 else f'{len(ks)} members'}"
                    for v, ks in sorted(by_count.items()))
    console.print(f"FE at the plant's resolution, elements per segment: {els}")
    console.print(f"max |error|: {thesis.max_error_pct():.2f} % (thesis mesh), "
                  f"{fine.max_error_pct():.2f} % (plant resolution)")
    for label, r in (("thesis mesh", thesis), ("plant resolution", fine)):
        if not r.unpaired:
            console.print(f"{label}: every MuJoCo mode up to {r.band_hz:.4g} Hz has an FE partner")
        for u in r.unpaired:
            console.print(f"{label}: MuJoCo mode {u.sim_mode} ({u.sim_hz:.4f} Hz) unpaired: {u.reason}")
    if decay is not None:
        console.print(f"free decay of mode 1: {decay.frequency_hz:.4f} Hz, zeta = {decay.damping_ratio:.4f}")
    for line in verdict_lines:
        console.print(line, highlight=False)


def _crosscheck_tolerance(refs: dict) -> tuple[dict, list[str]]:
    """The cross-check's verdict against :data:`vlab.sim.crosscheck.TOL_PCT` and ``MIN_MAC``: JSON fields, lines.

    ``within_tolerance`` is true when every FE mode of every reference (``refs``: name -> CrossCheck) is paired
    within the frequency tolerance and the MAC threshold; ``beyond_tolerance`` names each reference that is not,
    with its worst error and MAC; ``tolerance`` gives both limits and their source.
    """
    from .sim.crosscheck import MIN_MAC, TOL_PCT, TOLERANCE_SOURCE

    beyond, lines = {}, []
    for key, r in refs.items():
        if r.passed(TOL_PCT, MIN_MAC):
            continue
        err, mac = r.max_error_pct(), r.min_mac()
        worst = max(r.pairs, key=lambda p: abs(p.error_pct) if p.sim_mode is not None else math.inf)
        beyond[key] = {"max_abs_error_pct": err if math.isfinite(err) else None, "min_mac": mac,
                       "fe_mode": worst.fe_mode}
        label = key.replace("_", " ")
        err_text = f"{err:.2f} %" if math.isfinite(err) else "an unpaired FE mode"
        lines.append(f"BEYOND TOLERANCE ({label}): max |error| {err_text} (FE mode {worst.fe_mode}) against "
                     f"{TOL_PCT:g} %, min MAC {mac:.4f} against {MIN_MAC:g}")
    limits = f"|error| <= {TOL_PCT:g} %, MAC >= {MIN_MAC:g}"
    lines.append(f"tolerance: {limits} ({TOLERANCE_SOURCE})" if beyond else
                 f"within tolerance ({limits}) against every FE reference; source: {TOLERANCE_SOURCE}")
    return ({"within_tolerance": not beyond, "beyond_tolerance": beyond,
             "tolerance": {"max_abs_error_pct": TOL_PCT, "min_mac": MIN_MAC, "source": TOLERANCE_SOURCE}}, lines)


@app.command("export-mjcf", cls=_VlabCommand)
def export_mjcf_cmd(
    structure: str = _arg_structure(),
    output: str = _opt(None, "-o", "--output",
                       help="MJCF file to write, ending in .xml; its folder must exist (default: <structure>.xml)"),
    overwrite: bool = _flag("--overwrite", help="replace an existing file"),
) -> None:
    """Write the complete MuJoCo plant as MJCF, to edit and run with `vlab experiment --mjcf`."""
    from .io.atomic import check_output_file
    from .sim import build_plant, export_mjcf

    spec = _load_structure(structure)
    path = check_output_file(f"{spec.name}.xml" if output is None else output, overwrite=overwrite,
                             option="--output", suffix=".xml")
    written = export_mjcf(build_plant(spec), path, overwrite=overwrite)
    console.print(f"wrote {escape(str(written))}", highlight=False)


class TemplateKind(str, Enum):
    beam = "beam"
    frame = "frame"
    bcc = "bcc"
    grid = "grid"


@app.command("init", cls=_VlabCommand)
def init_cmd(
    kind: TemplateKind = typer.Argument(..., help="template: beam (clamped-free beam, two coils), frame (planar "
                                                  "portal frame, two coils), or a copy of bcc or grid",
                                        show_default=False),
    path: str = typer.Argument(..., help="structure file to write, ending in .toml; its folder must exist",
                               show_default=False),
    overwrite: bool = _flag("--overwrite", help="replace an existing file"),
) -> None:
    """Write a commented structure file (with its test and design tables) to edit and run like bcc or grid."""
    from .templates import write_template

    written = write_template(kind.value, path, overwrite=overwrite)
    console.print(f"wrote {escape(str(written))}; try `vlab modes {escape(str(written))}`", highlight=False)


REPRODUCE_OUT = "out/reproduce"
DIAGNOSE_OUT = "out/diagnose"
DIAGNOSE_PLANTS = ("auto", "linear", "mujoco")


@app.command(cls=_VlabCommand)
def reproduce(
    out: str = _opt(REPRODUCE_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = _flag("--overwrite", help="replace an existing non-empty output folder"),
    fast: bool = _flag("--fast", help="only the quick subset of tables"),
    plant: PlantKind = _opt(PlantKind.linear, "--plant",
                            help="plant of the virtual experiments: MuJoCo or the linear FE model (fast)"),
) -> None:
    """Regenerate the dissertation's tables side by side with the published numbers (written atomically)."""
    from .reproduce import reproduce as run_reproduce

    out_path = _out_dir(out, REPRODUCE_OUT, overwrite)
    _expect_output(out_path)
    if out == REPRODUCE_OUT:
        out_path.absolute().parent.mkdir(parents=True, exist_ok=True)
    run_reproduce(out_path, fast=fast, plant=plant.value, progress=True, console=console, overwrite=overwrite)


@app.command(cls=_VlabCommand)
def diagnose(
    structure: str = _opt(..., "--structure", help=STRUCTURE_HELP, metavar=STRUCTURE_METAVAR),
    recording: str = _opt(..., "--recording",
                          help="the recording: UFF 58 time histories (as `vlab experiment` writes) or FRFs, "
                               "or a CSV modal table"),
    controller: ExpController = _opt(None, "--controller",
                                     help="controller that was running during the recording (none = open loop; "
                                          "default: the recording's metadata, else none)"),
    force: bool = _flag("--force", help="use --controller/--plant even where the recording's metadata says "
                                        "otherwise"),
    out: str = _opt(DIAGNOSE_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = _flag("--overwrite", help="replace an existing non-empty output folder"),
    plant: str = _opt("auto", "--plant", metavar="<auto|linear|mujoco>",
                      help="plant of the replay and the validation rerun: auto (the plant the recording's "
                           "metadata names, else MuJoCo), linear or mujoco"),
    baseline: str = _opt(None, "--baseline",
                         help="a measured reference: recording of the same test on the structure before the "
                              "change (default: the recorded force replayed on the nominal plant)"),
    mjcf: str = _opt(None, "--mjcf", help="the nominal plant as an MJCF file (from `vlab export-mjcf`, edited): the "
                                          "recorded force is replayed on it (default: the plant built from the "
                                          "structure); needs a MuJoCo-plant recording"),
    reference_column: str = _opt(None, "--reference-column",
                                 help="modal tables: compare with this column's frequencies (e.g. analytical_hz, "
                                      "a published analysis) instead of vlab's model; the model predicts what "
                                      "an effect changes (default: none, compared with vlab's model)"),
    model_form: str = _opt("auto", "--model-form", metavar="<auto|derived|none>",
                           help="the model's own uncertainty in the decision: derived (from its calibration and "
                                "discretisation), none (the data come from this model itself), auto (none for a "
                                "recording whose metadata names the vlab plant that made it or with --baseline, "
                                "else derived)"),
    false_alarm_rate: float = _opt(0.01, "--false-alarm-rate", metavar="<alpha>",
                                   help="probability [1], in (0, 0.5), of reporting a mismatch on a recording of "
                                        "the nominal structure; every threshold of the decision follows from it "
                                        "(chi-square and single-line limits, the likelihood-ratio test)"),
    fmt: OutputFormat = _format_opt(),
    as_json: bool = _flag("--json", help="print one JSON object instead of the table (= --format json)"),
) -> None:
    """Locate a mismatch between a recording and the simulation, name and fit the missing physics."""

    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from .diagnose import diagnose as run_diagnose
    from .io.atomic import atomic_dir

    from .diagnose.policy import DecisionPolicy

    out_fmt = _output_format(fmt, as_json)
    DecisionPolicy(false_alarm_rate=false_alarm_rate)  # a bad rate is refused before any work
    spec = _load_structure(structure)
    out_path = _out_dir(out, DIAGNOSE_OUT, overwrite)
    if plant not in DIAGNOSE_PLANTS:
        raise OptionError(f"--plant {plant!r} is not one of {', '.join(DIAGNOSE_PLANTS)}")
    _input_file("--recording", recording)
    _input_file("--baseline", baseline)
    _mjcf_input(mjcf)
    _expect_output(out_path)
    with Progress(SpinnerColumn(), TextColumn("diagnose: {task.description}"), TimeElapsedColumn(),
                  console=err_console, transient=True, disable=out_fmt != "table") as bar:
        task = bar.add_task("reading the recording", total=None)
        with atomic_dir(out_path, overwrite=overwrite, create_parent=out == DIAGNOSE_OUT) as tmp:
            res = run_diagnose(spec, Path(recording), out_dir=tmp, plant=plant, baseline=baseline, mjcf=mjcf,
                               controller=None if controller is None else controller.value, force=force,
                               overwrite=False, reference_column=reference_column, model_form=model_form,
                               false_alarm_rate=false_alarm_rate,
                               progress=lambda stage: bar.update(task, description=escape(str(stage))))
    res.files = {k: out_path / Path(v).relative_to(tmp) for k, v in res.files.items()}
    if out_fmt == "json":
        _print_json(res.as_dict())
        return
    d = res.as_dict()
    if out_fmt == "csv":
        _diagnosis_csv(d)
        return
    _print_diagnosis(d, out_path)


def _diagnosis_csv(d: dict[str, Any], out=None) -> None:
    """Every ranked hypothesis of ``d`` (:meth:`DiagnosisResult.as_dict`) as one CSV line on ``out`` (stdout).

    Columns: rank, effect, location, parameters (SI, with 95 % intervals), BIC difference to the best, misfit
    after the effect is modelled (its unit in the column name: decades for FRF data).
    """
    from .diagnose.report.text import hypothesis_rows, misfit_unit
    from .io.tabular import Column, write_csv

    unit = misfit_unit(d).replace(".", "").replace(" ", "_")
    rows = [{"rank": i, "effect": r["effect"], "location": r["location"], "parameters_si_ci95": r["parameters"],
             "delta_bic": r["delta_bic"], f"misfit_after_{unit}": r["misfit_after"]}
            for i, r in enumerate(hypothesis_rows(d, limit=None), start=1)]
    write_csv(rows, [Column("rank", ""), Column("effect", ""), Column("location", ""),
                     Column("parameters_si_ci95", ""), Column("delta_bic", ""), Column(f"misfit_after_{unit}", "")],
              out or sys.stdout)


DETECT_OUT = "out/detectability"


@app.command(cls=_VlabCommand)
def detectability(
    structure: str = _arg_structure(),
    controller: ExpController = _opt(ExpController("none"), "--controller",
                                     help="controller running during the test (none = open loop)"),
    effect: list[str] = _opt(None, "--effect", metavar="<effect>",
                             help="only this effect of the library (repeatable; default: all one-parameter "
                                  "effects): added_mass, support_stiffness, joint_flexibility, member_stiffness, "
                                  "damping, loop_delay, actuator_lag, sensor_lag, actuator_gain, sensor_gain, "
                                  "gravity_prestress, saturation"),
    noise: float = _opt(1e-6, "--noise", help="velocity-sensor noise standard deviation [m/s], >= 0"),
    seed: int = _opt(0, "--seed", help="seed of the excitation, the noise and the design's multi-start"),
    out: str = _opt(None, "--out", help="also write detectability.json and a figure into this folder"),
    overwrite: bool = _flag("--overwrite", help="replace an existing non-empty output folder"),
    model_form: str = _opt("derived", "--model-form", metavar="<derived|none>",
                           help="derived: thresholds of a real measurement, within the model's own uncertainty "
                                "(calibration residual, plant discretisation); none: of a recording made by the "
                                "model itself"),
    naming: bool = typer.Option(True, "--naming/--no-naming",
                                help="also the smallest size at which the diagnosis names the effect among its "
                                     "look-alikes (every one-parameter effect of the library; minutes)"),
    fmt: OutputFormat = _format_opt(),
    as_json: bool = _flag("--json", help="print one JSON object instead of the table (= --format json)"),
) -> None:
    """Smallest size of each effect of the library, at each location, that the diagnosis detects and names."""
    import json
    import math
    from contextlib import nullcontext

    from .diagnose.detectability import detectability as run, figure
    from .diagnose.report.text import format_location, parameter_unit
    from .io.atomic import atomic_dir
    from .experiment.results import jsonable
    from .io.tabular import Column

    from .diagnose.effects.hypotheses import EFFECTS

    out_fmt = _output_format(fmt, as_json)
    if not (math.isfinite(noise) and noise >= 0):
        raise OptionError(f"--noise must be a finite number >= 0 [m/s], got {noise!r}")
    unknown = [e for e in effect or () if e not in EFFECTS]
    if unknown:
        raise OptionError(f"--effect {', '.join(unknown)}: not an effect of the library ({', '.join(EFFECTS)})")
    spec = _load_structure(structure)
    _seed(seed)
    out_path = _out_dir(out, DETECT_OUT, overwrite) if out is not None else None
    with err_console.status("detectability: recording the nominal test and searching the thresholds",
                            spinner="dots") if out_fmt == "table" else nullcontext():
        res = run(spec, controller.value, effects=tuple(effect) if effect else None, noise_m_s=noise, seed=seed,
                  model_form=model_form, naming=naming)
    d = res.as_dict()
    if out_path is not None:
        with atomic_dir(out_path, overwrite=overwrite, create_parent=False) as tmp:
            (tmp / "detectability.json").write_text(json.dumps(jsonable(d), indent=2))
            figure(res, spec, tmp / "added_mass.png")
    if out_fmt == "json":
        _print_json(d)
        return
    rows = []
    for t in res.thresholds:
        q, unit = parameter_unit(t.parameter)
        rel = (100 * (t.threshold / t.null - 1) if t.threshold is not None and t.null not in (None, 0.0) else None)
        rows.append({"effect": t.effect, "location": format_location(t.location),
                     "parameter": f"{q} [{unit}]" if unit else q,
                     "null": "limit" if t.null is None else f"{t.null:.4g}",
                     "threshold": "not detected in range" if t.threshold is None else f"{t.threshold:.3g}",
                     "change_pct": rel, "test": t.by or "",
                     "named": ("" if not naming else "not named in range" if t.named_at is None
                               else f"{t.named_at:.3g}"),
                     "look_alike": (f"{t.look_alike} ({t.look_alike_chi2:.3g})" if t.look_alike else "")})
    cols = [Column("effect", "effect"), Column("location", "location"), Column("parameter", "parameter [unit]"),
            Column("null", "null value"), Column("threshold", "threshold"),
            Column("change_pct", "change [%]", "+.3g"), Column("test", "found by")]
    if naming:
        cols += [Column("named", "named from"), Column("look_alike", "closest look-alike (chi2)")]
    _print_rows(out_fmt, rows, cols, f"{spec.title}, {controller.value}: smallest detectable size of each effect "
                                       f"(noise {noise:g} m/s; chi2 limit {res.chi2_limit:.4g}, "
                                       f"N = {res.n_obs})")
    if out_fmt == "table" and res.skipped:
        console.print(f"not computed (more than one parameter): {', '.join(res.skipped)}", highlight=False)


ROBUSTNESS_OUT = "out/robustness"


@app.command(cls=_VlabCommand)
def robustness(
    structure: str = typer.Argument(..., help="structure: bcc (Beam Cross-Cable) or grid (Hanging Grid)",
                                    show_default=False),
    samples: str = _opt("1000", "--samples", metavar="<integer>",
                        help="Monte Carlo samples, >= 1 (1e4 is read as 10000); a study estimated to take more "
                             "than 30 min asks for --yes"),
    seed: int = _opt(0, "--seed", help="seed of the draws (sample i draws from default_rng([seed, i])) and of the "
                                       "designs' multi-start, an integer in [0, 2**32)"),
    uncertainty: str = _opt(None, "--uncertainty",
                            help="TOML of distributions ([parameters.<group>] kind, spread, source) replacing the "
                                 "defaults: EI ±5 %, section mass ±3 %, cable tension ±10 %, lumped masses ±10 %, "
                                 "coil masses ±10 %, support springs ±10 %, delay 1.15-1.55 periods, actuator "
                                 "gains ±5 %, sensor gains ±5 %, all uniform and assumed (the dissertation states "
                                 "no tolerances; EI measured, Sec. 2.1; masses calibrated, Tables 1 and 8; delay "
                                 "1.35 periods measured, Sec. 5.3); each group's source in robustness.json"),
    scheduler: str = _opt("local", "--scheduler",
                          help="where the chunks run: local (a Dask LocalCluster, one process per CPU), none "
                               "(this process) or tcp://HOST:PORT (an existing Dask scheduler, which must answer "
                               "within 8 s, before any computation)"),
    workers: int = _opt(None, "--workers", help="processes of the local cluster (default: one per CPU)"),
    chunk_size: int = _opt(25, "--chunk-size", help="samples per independent chunk, >= 1"),
    controllers: str = _opt("mfdrf,lqdrf,lqdrf-diag,lqg", "--controllers",
                            help="comma-separated subset of mfdrf, lqdrf, lqdrf-diag, lqg"),
    simulate: int = _opt(4, "--simulate",
                         help="worst samples per controller (by the linear measure) also run in time on the "
                              "batched MuJoCo lab, >= 0"),
    simulate_random: int = _opt(None, "--simulate-random",
                                help="samples per controller drawn at random and run on the MuJoCo lab, >= 0: "
                                     "the MuJoCo plant's P(unstable) is estimated from them (default: 100 for the "
                                     "BCC, 10 for the grid, whose 12 s runs take about 6 s each)"),
    yes: bool = _flag("--yes", help="run a study estimated to take more than 30 min"),
    out: str = _opt(ROBUSTNESS_OUT, "--out", help="output folder (its parent must exist)"),
    overwrite: bool = _flag("--overwrite", help="replace an existing non-empty output folder"),
    markdown_copy: str = _opt(None, "--markdown", help="also write robustness.md to this file, e.g. "
                                                        "docs/robustness.md; an existing file is replaced only "
                                                        "with --overwrite (default: none)"),
    as_json: bool = _flag("--json", help="print robustness.json to stdout instead of the table"),
) -> None:
    """Monte Carlo robustness of MFDRF, LQDRF, LQDRF-diag and LQG, designed on the nominal model (Sec. 7).

    Per controller and per plant: P(unstable) with its Wilson interval, the median analysis/experiment
    peak-ratio error (Table 10) and the damping change with their intervals. Plants: the exact sampled-data
    loop on every perturbed FE model, and the MuJoCo plant run in time for the worst and for randomly drawn
    samples (a run that self-excites counts as unstable there and its peak ratios are not used). Outputs:
    robustness.json, samples.npz, robustness.png, worst_time_history.png, robustness.md, worst.rrd.
    """
    from .io.atomic import atomic_dir
    from .robust.pipeline import DEFAULT_RANDOM, run_pipeline
    from .robust.report import write_outputs
    from .robust.scheduler import confirm_size, parse_samples, parse_scheduler
    from .robust.study import CONTROLLERS as CONTROLLER_ORDER
    from .robust.study import StudyConfig, default_workers
    from .robust.uncertainty import DEFAULTS, load_uncertainties

    _seed(seed)
    if structure not in ("bcc", "grid"):
        raise OptionError(f"robustness: structure {structure!r} is not one of bcc, grid (the study's "
                          "uncertainties are stated for the dissertation's structures)")
    n_samples = parse_samples(samples)
    sched = parse_scheduler(scheduler)
    if workers is not None and workers < 1:
        raise OptionError(f"--workers must be >= 1, got {workers!r}")
    simulate_random = DEFAULT_RANDOM[structure] if simulate_random is None else simulate_random
    for name, value in (("--simulate", simulate), ("--simulate-random", simulate_random)):
        if value < 0:
            raise OptionError(f"{name} must be >= 0, got {value!r}")
    cfg_controllers = tuple(c.strip() for c in controllers.split(",") if c.strip())
    confirm_size(samples, structure, n_samples, len(cfg_controllers),
                 1 if sched is None else (workers or default_workers()), yes,
                 runs=len(cfg_controllers) * (min(simulate + simulate_random, n_samples) + 1))
    out_path = _out_dir(out, ROBUSTNESS_OUT, overwrite)
    if markdown_copy is not None:
        from .io.atomic import check_output_file

        check_output_file(markdown_copy, overwrite=overwrite, option="--markdown")
    _input_file("--uncertainty", uncertainty)
    uncs = load_uncertainties(uncertainty) if uncertainty else DEFAULTS
    cfg = StudyConfig(structure=structure, n_samples=n_samples, seed=seed, uncertainties=uncs,
                      chunk_size=chunk_size, controllers=cfg_controllers)
    _expect_output(out_path)
    nominal, res, summary, checks, timings, extras = run_pipeline(
        cfg, scheduler=sched, workers=workers, n_worst=simulate, n_random=simulate_random)
    command = f"vlab robustness {structure} --samples {n_samples} --seed {seed}" + (
        f" --uncertainty {uncertainty}" if uncertainty else "") + (
        f" --controllers {controllers}" if cfg.controllers != CONTROLLER_ORDER else "") + (
        f" --simulate {simulate}" if simulate != 4 else "") + (
        f" --simulate-random {simulate_random}" if simulate_random != DEFAULT_RANDOM[structure] else "")
    with atomic_dir(out_path, overwrite=overwrite, create_parent=out == ROBUSTNESS_OUT) as tmp:
        files = write_outputs(tmp, cfg, nominal, res, summary, checks, timings, command, extras=extras)
    if markdown_copy is not None:
        from .io.atomic import atomic_file

        with atomic_file(markdown_copy, overwrite=overwrite) as tmp_md:
            tmp_md.write_text((out_path / "robustness.md").read_text())
    if as_json:
        _print_json(json.loads((out_path / "robustness.json").read_text()))
        return
    _print_robustness(json.loads((out_path / "robustness.json").read_text()), n_samples, structure)
    console.print(f"outputs: {escape(str(out_path))}/ ({len(files)} files) in {timings['total']:.0f} s",
                  highlight=False)


def _print_robustness(data: dict, n_samples: int, structure: str) -> None:
    """The per-plant table of ``vlab robustness`` (probabilities with Wilson intervals) and Sec. 7 per plant."""
    names = {"fe_sampled_loop": "FE sampled loop", "mujoco_time_simulation": "MuJoCo, time simulation"}
    t = Table(title=f"{structure}: {n_samples} samples, controllers designed on the nominal model")
    for col in ("controller", "plant", "samples", "P(unstable) [95 %]", "peak-ratio error [dB]", "damping change",
                "works at nominal"):
        t.add_column(col, justify="right")
    for c in data["per_plant"]["fe_sampled_loop"]:
        for plant, per in data["per_plant"].items():
            v = per[c]
            p, ci = v["probability_unstable"], v["probability_unstable_ci95"]
            e, dz = v["peak_ratio_error_db_median"], v.get("damping_change_relative_median")
            n = v.get("samples", v.get("simulated_random_samples"))
            t.add_row(c, names.get(plant, plant), str(n),
                      "n/a" if p is None else f"{100 * p:.1f} % [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]",
                      "n/a" if e is None else f"{e:.3f}", "n/a" if dz is None else f"{100 * dz:.2f} %",
                      {True: "yes", False: "no"}.get(v.get("working_loop_at_nominal"), ""))
    console.print(t)
    for plant, text in data["sec7_on_plants"].items():
        console.print(f"Sec. 7 on the {names.get(plant, plant)}: {text}", highlight=False, soft_wrap=True)


def _print_diagnosis(d: dict[str, Any], out_path) -> None:
    """The ranked hypotheses as a table (units in the headers and cells) and the one-paragraph verdict."""
    from .diagnose.report.text import hypothesis_rows, misfit_unit
    from .diagnose.report.verdict import verdict

    rows = hypothesis_rows(d, limit=8)
    unit = misfit_unit(d)
    if rows:
        t = Table(title=f"ranked hypotheses (best {len(rows)} of {len(d['ranked'])}; BIC: lower is better)")
        for col, justify in (("#", "right"), ("effect", "left"), ("location", "left"),
                             ("parameters, SI [95 % interval]", "left"), ("dBIC to the best", "right"),
                             (escape(f"misfit after [{unit}]"), "right")):
            t.add_column(col, justify=justify, overflow="fold")
        for i, r in enumerate(rows, start=1):
            t.add_row(str(i), escape(r["effect"]), escape(r["location"]), escape(r["parameters"]),
                      r["delta_bic"], r["misfit_after"])
        console.print(t)
    console.print(escape(verdict(d)), highlight=False)
    console.print(f"report: {escape(str(out_path / 'diagnosis.md'))}", highlight=False)


# ------------------------------------------------------------------ option checks (before any work) ---


def _number(option: str, value: float | None, *, low: float | None = None, high: float | None = None,
            low_open: bool = False, what: str = "a number") -> float | None:
    """``value`` of ``option`` checked finite and in range (None passes); raises OptionError naming both."""
    if value is None:
        return None
    v = float(value)
    if not math.isfinite(v):
        raise OptionError(f"{option} must be a finite number ({what}), got {value!r}")
    if low is not None and (v < low or (low_open and v == low)):
        raise OptionError(f"{option} must be {'>' if low_open else '>='} {low:g} ({what}), got {value!r}")
    if high is not None and v > high:
        raise OptionError(f"{option} must be <= {high:g} ({what}), got {value!r}")
    return v


def _seed(value: int) -> int:
    if value < 0 or value >= 2**32:
        raise OptionError(f"--seed must be an integer in [0, 2**32), got {value!r}")
    return value


def _input_file(option: str, value: str | None) -> str | None:
    """A file to read: exists and is a regular file (None passes)."""

    from .errors import DataFileError

    if value is None:
        return None
    if str(value).strip() == "":
        raise OptionError(f"{option}: an empty path is not a file")
    p = Path(value)
    if not p.exists():
        raise DataFileError(f"{option} {value}: file not found")
    if not p.is_file():
        raise DataFileError(f"{option} {value}: not a regular file")
    return value


def _mjcf_input(value: str | None) -> str | None:
    """``--mjcf``: a regular file whose includes and assets stay in its folder (:func:`vlab.io.confine.check_mjcf_files`)."""
    from .io.confine import check_mjcf_files

    if _input_file("--mjcf", value) is not None:
        check_mjcf_files(value)
    return value


def _out_dir(value: str, default: str, overwrite: bool):
    """``--out`` checked (:func:`vlab.io.atomic.check_output_dir`); the default's parent ``out/`` may be created."""
    from .io.atomic import check_output_dir

    return check_output_dir(value, overwrite=overwrite, option="--out", create_parent=(value == default))


def available_memory_bytes() -> int | None:
    """Memory available to a new run [bytes]: ``MemAvailable`` of ``/proc/meminfo``, else ``os.sysconf``.

    Returns
    -------
    int or None
        Bytes, or None where the system does not say.
    """
    import os

    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


#: Rough controller ticks per second of the experiment loop (measured on the development machine,
#: 2 shared cores, open loop, 40 s BCC / 100 s grid runs): linear plant ~4800, MuJoCo BCC ~3600;
#: the MuJoCo grid (more bodies) is taken slower. Only for the time estimate shown before a run.
LOOP_TICKS_PER_S = {("linear", "bcc"): 4800.0, ("linear", "grid"): 4800.0,
                    ("mujoco", "bcc"): 3600.0, ("mujoco", "grid"): 1500.0}
#: Memory bandwidth assumed for the delay line's per-tick shift [bytes/s] (time estimate only).
SHIFT_BYTES_PER_S = 2e9


def estimate_experiment(fe, *, plant: str, period_s: float, duration_s: float | None,
                        delay_periods: float) -> dict[str, float]:
    """Memory and time an experiment run would need, estimated before it starts.

    Memory: the loop's per-tick arrays (velocities of the measured points,
    displacements of the shape points, commands, excitation, time) with the
    copies the recording, H1 and the rerun log make (x3 for the signals), and
    the computation-delay line (the DAC buffer of :class:`vlab.lab.batch_chain.ChainRun`,
    ``floor(D) + 2`` samples per actuator, x3: buffer, shift copy, state).
    Time: ticks / :data:`LOOP_TICKS_PER_S` plus the delay line's per-tick
    shift at :data:`SHIFT_BYTES_PER_S`.

    Parameters
    ----------
    fe : FEModel
        The nominal FE model (its spec selects the test of Sec. 5.4).
    plant : {"linear", "mujoco"}
        Plant kind.
    period_s : float
        Controller sampling period [s].
    duration_s : float or None
        Run length [s]; None = the default (settling records of the slowest
        open-loop mode, :func:`vlab.experiment.settling.settle_records`, plus the
        measured records).
    delay_periods : float
        Computation delay [sampling periods].

    Returns
    -------
    dict
        ``duration_s``, ``n_ticks``, ``memory_bytes``, ``time_s``.

    Raises
    ------
    SpecError
        Structure without a test definition (:func:`vlab.experiment.config.test_definition`).
    """
    from .experiment.config import ExperimentConfig, test_definition
    from .experiment.settling import settle_records, slowest_decay_rate

    test = test_definition(fe.spec)
    record_s = 1.0 / test.resolution_hz
    if duration_s is None:
        n_settle = settle_records(slowest_decay_rate(fe, None), record_s)
        duration_s = (n_settle + ExperimentConfig.periods - 1) * record_s
    n_ticks = math.floor(duration_s / period_s + 1e-9)
    acts = tuple(fe.spec.instrumentation.actuators)
    n_meas = len(dict.fromkeys(tuple(test.measured_points) + acts))
    n_shape = sum(1 for p in fe.spec.points if (p, "w") in fe.dofs)
    per_tick = 8.0 * (3 * (n_meas + n_shape + len(acts)) + 4)
    delay_bytes = 8.0 * (math.floor(delay_periods) + 2) * len(acts)
    rate = LOOP_TICKS_PER_S.get((plant, fe.spec.name), 1500.0)
    return {"duration_s": float(duration_s), "n_ticks": float(n_ticks),
            "memory_bytes": n_ticks * per_tick + 3 * delay_bytes,
            "time_s": n_ticks / rate + n_ticks * delay_bytes / SHIFT_BYTES_PER_S}


def _human_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"


def _human_s(t: float) -> str:
    if t < 120:
        return f"{t:.0f} s"
    if t < 7200:
        return f"{t / 60:.0f} min"
    if t < 48 * 3600:
        return f"{t / 3600:.1f} h"
    return f"{t / 86400:.3g} days"


def _guard_experiment(fe, *, plant: str, period_s: float, duration_s: float | None, delay_periods: float,
                      quiet: bool) -> dict[str, float]:
    """Refuse a run that cannot fit in memory or whose delay exceeds it; print the estimate."""
    est = estimate_experiment(fe, plant=plant, period_s=period_s, duration_s=duration_s, delay_periods=delay_periods)
    if delay_periods >= est["n_ticks"]:
        raise OptionError(f"--delay-samples {delay_periods:g} is longer than the whole run "
                          f"({est['n_ticks']:.0f} sampling periods of {est['duration_s']:g} s): the controller "
                          "output would never reach the coils")
    avail = available_memory_bytes()
    if avail is not None and est["memory_bytes"] > 0.8 * avail:
        raise ResourceError(
            f"the run ({est['duration_s']:g} s, {est['n_ticks']:.3g} ticks, delay line {delay_periods:g} "
            f"periods) would need about {_human_bytes(est['memory_bytes'])} of memory; "
            f"{_human_bytes(avail)} is available: shorten --duration or --delay-samples")
    if not quiet:
        bound = "at most " if duration_s is None else ""  # the open loop's settling: a controller settles sooner
        err_console.print(f"estimate: {bound}{est['duration_s']:g} s simulated, {est['n_ticks']:.0f} ticks, "
                          f"~{_human_bytes(est['memory_bytes'])} memory, {bound}~{_human_s(est['time_s'])} for the "
                          "loop (plus design and outputs)", highlight=False, soft_wrap=True)
    return est



#: Range of ``--period-ms`` [ms]: from 10x the PC-1000's fastest rate (2 kHz, Sec. 5.3) to a Nyquist
#: frequency of 10 Hz, the top of the grid's test band (the BCC's, 25 Hz, needs <= 20 ms).
PERIOD_MS_RANGE = (0.05, 50.0)


def _period_s(period_ms: float | None) -> float | None:
    """``--period-ms`` in seconds (None stays None); raises OptionError outside :data:`PERIOD_MS_RANGE`."""
    if period_ms is None:
        return None
    if not (math.isfinite(period_ms) and period_ms > 0):
        raise OptionError(f"--period-ms must be a positive number of milliseconds, got {period_ms!r}")
    v = _number("--period-ms", period_ms, low=PERIOD_MS_RANGE[0], high=PERIOD_MS_RANGE[1],
                what="controller sampling period [ms]")
    return v * 1e-3


def _measured_modes(fe, modes_file: str | None):
    """Measured modes (frequencies, shapes at the Guyan masters) for corrected-guyan."""
    from .errors import DataFileError
    from .models import master_indices

    if modes_file is None:
        if "frequencies" not in fe.spec.reference:
            raise OptionError(f"--reduction corrected-guyan: structure {fe.spec.name!r} has no published frequency "
                              "table ([reference] frequencies) for a virtual modal test: give --modes FILE (UFF 55)")
        return _virtual_measured_modes(fe)
    from .io.uff import read_mode_shapes

    ms = read_mode_shapes(modes_file)
    idx = master_indices(fe, "guyan")
    labels = [fe.dofs.labels[i] for i in idx]
    rows = []
    for node, dof in labels:
        if dof != "w":
            raise DataFileError(f"{modes_file}: the Guyan master {dof}@{node} is a rotation; UFF 55 gives translations only")
        if node not in ms.point_ids:
            raise DataFileError(f"{modes_file}: no shape value at master point {node}")
        rows.append(list(ms.point_ids).index(node))
    return np.asarray(ms.freq_hz), np.real(np.asarray(ms.shapes))[rows, :]


def _virtual_measured_modes(fe):
    """:func:`vlab.sim.modaltest.virtual_measured_modes`, saying on stderr where the modes come from."""
    from .sim.modaltest import virtual_measured_modes

    freq, shapes = virtual_measured_modes(fe)
    err_console.print(
        f"corrected-guyan: {len(freq)} modes, shapes from a virtual modal test on the MuJoCo plant (paired with the "
        f"FE modes by MAC), frequencies from {fe.spec.reference['frequencies']} (experimental)"
    )
    return freq, shapes


from . import cli_update  # noqa: E402,F401  (registers `vlab update` on app)


def main() -> None:  # pragma: no cover - console entry
    app()
