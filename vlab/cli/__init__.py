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

Modules
-------
program
    The typer app (:data:`app`), its root options and the commands in help order.
runtime
    The single error path: exit statuses, Ctrl-C, the command and group classes.
output, options, checks
    What is printed (consoles, tables, CSV, JSON); the shared options and their help texts; the checks of
    option values, run before any work.
modes, design, experiment, crosscheck, init, reproduce, diagnose, robustness, update
    One module per command or group of commands (``experiment`` also holds ``export-mjcf``,
    ``diagnose`` also ``detectability``).
"""

from .program import app, main

__all__ = ["app", "main"]
