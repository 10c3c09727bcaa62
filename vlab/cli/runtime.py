"""The command line's single error path: exit statuses, Ctrl-C, and the command and group classes of the app.

A failure is printed as one line ``error: <message>`` on stderr, with no traceback unless ``--debug``; the
exit statuses are listed in :mod:`vlab.cli`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from rich.markup import escape
from typer.core import TyperCommand, TyperGroup
from typer.exceptions import Abort, Exit, TyperException

from ..errors import BAD_INPUT_ERRORS, MeasurementError, VlabError
from .output import err_console, error_line

EPILOG = ("Exit status: 0 success; 1 failed run (simulation diverged, measurement failed during a run, "
          "not-meaningful comparison, write error); 2 bad input (option, output path, spec, data file, model, "
          "run too large for the machine), refused before any work starts; 130 interrupted (nothing written). "
          "Errors are one line without traceback; --debug shows the traceback.")

#: Per-invocation state: ``debug`` (the root's --debug), the message of an interrupt, the output folder
#: expected (and the identity of what is there now), whether SIGINT arrived.
STATE: dict[str, Any] = {"debug": False, "interrupted": "interrupted: nothing written"}

#: Former option names still accepted but not shown in ``--help``.
HIDDEN_ALIASES = frozenset({"--delay-samples"})


def exit_code(exc: BaseException, command: str | None) -> int:
    """Exit status of an exception (the mapping in :mod:`vlab.cli`)."""
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


class VlabCommand(TyperCommand):
    """A command whose ``--help`` option is shown without a type.

    An option name of :data:`HIDDEN_ALIASES` is taken off its option (so that no help, generated
    documentation or error message shows it) and given back to the parser only, which still reads it.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.hidden_aliases: dict[str, list[str]] = {}
        for p in self.params:
            aliases = [o for o in p.opts if o in HIDDEN_ALIASES]
            if aliases:
                p.opts = [o for o in p.opts if o not in HIDDEN_ALIASES]
                self.hidden_aliases[p.name] = aliases

    def get_help_option(self, ctx):
        return _untyped_help_option(super().get_help_option(ctx))

    def make_parser(self, ctx):
        parser = super().make_parser(ctx)
        for p in self.get_params(ctx):
            aliases = self.hidden_aliases.get(p.name)
            if aliases:
                shown, p.opts = p.opts, aliases
                try:
                    p.add_to_parser(parser, ctx)
                finally:
                    p.opts = shown
        return parser


class VlabGroup(TyperGroup):
    """The app's group: turns every exception of a command into one error line and an exit status."""

    def get_help_option(self, ctx):
        return _untyped_help_option(super().get_help_option(ctx))

    def invoke(self, ctx) -> Any:
        STATE["debug"] = False  # set by the callback (--debug)
        STATE["interrupted"] = "interrupted: nothing written"
        STATE["out_path"] = STATE["out_id"] = None
        from ..io.atomic import clear_interrupt_request, interrupt_requested
        from ..io.confine import ALLOW_ENV

        clear_interrupt_request()

        allow_env = os.environ.get(ALLOW_ENV)
        restore = _install_sigint_flag()
        try:
            result = super().invoke(ctx)
            if interrupt_requested() and not STATE["debug"]:
                # the KeyboardInterrupt was dropped where it was raised (a garbage-collection callback)
                _interrupted()
            return result
        except (Exit, Abort, TyperException):  # exits, usage errors: typer's own handling
            raise
        except KeyboardInterrupt:
            if STATE["debug"]:
                raise
            _interrupted()
        except Exception as exc:  # noqa: BLE001 - the single error path of the CLI
            if STATE["debug"]:
                raise
            if interrupt_requested():  # a library turned the KeyboardInterrupt into its own error (pyuff does)
                _interrupted()
            command = ctx.invoked_subcommand
            error_line(_message(exc, command))
            raise Exit(exit_code(exc, command)) from None
        finally:
            restore()
            _default_sigint_at_exit()
            clear_interrupt_request()  # an in-process caller's later writes are not refused
            from ..io.manifest import release_lock

            release_lock()  # the output folder's lock, when the command ended before writing it
            if allow_env is None:
                os.environ.pop(ALLOW_ENV, None)
            else:
                os.environ[ALLOW_ENV] = allow_env


def _message(exc: Exception, command: str | None) -> str:
    """The one-line message of a command's exception."""
    if isinstance(exc, (VlabError, OSError, UnicodeDecodeError)):
        text = str(exc) or type(exc).__name__
        if isinstance(exc, OSError) and not isinstance(exc, VlabError):
            text = f"{str(exc.filename) + ': ' if exc.filename else ''}{exc.strerror or exc}"
        return text
    if isinstance(exc, MemoryError):
        return f"out of memory ({exc}); shorten the run or free memory"
    return (f"internal error {type(exc).__name__}: {exc} (run `vlab --debug {command or ''} ...` for "
            "the traceback and report it)")


def expect_output(out_path: Path) -> None:
    """Remember the output folder (and the identity of what is there now) for the message of an interrupt."""
    STATE["interrupted"] = f"interrupted: nothing written ({out_path} unchanged)"
    STATE["out_path"] = out_path
    STATE["out_id"] = _folder_id(out_path)


def _folder_id(path: Path) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


def _interrupted() -> None:
    text = STATE["interrupted"]
    out_path = STATE.get("out_path")
    if out_path is not None and _folder_id(out_path) != STATE.get("out_id"):
        # the new folder was renamed into place before the interrupt landed (the rename is atomic)
        text = f"interrupted after the outputs were written to {out_path}"
    err_console.print(escape(text), soft_wrap=True, highlight=False)
    raise Exit(130) from None


def _default_sigint_at_exit() -> None:
    """At interpreter exit, before the libraries' own exit callbacks, give SIGINT its default action.

    The command is over when its exit callbacks run (rerun's flushes its runtime); a Ctrl-C landing
    there would raise a ``KeyboardInterrupt`` inside the callback and print a traceback after a complete
    run. With the default action the process ends by the signal instead, as it does once Python has
    finished its callbacks. Exit callbacks run last-registered first, so the callback is registered
    again after every command (which may have imported such a library).
    """
    import atexit

    atexit.unregister(_sigint_default_if_python_handler)
    atexit.register(_sigint_default_if_python_handler)


def _sigint_default_if_python_handler() -> None:
    import signal
    import threading

    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        signal.signal(signal.SIGINT, signal.SIG_DFL)


def _install_sigint_flag():
    """While a command runs, Ctrl-C is also recorded by :func:`vlab.io.atomic.request_interrupt`.

    A library may swallow the ``KeyboardInterrupt``, and Python drops one raised inside a
    garbage-collection callback; the record makes the outputs' commit refuse and the command end
    with the interrupt's message and status all the same.

    Only where SIGINT has Python's default handler (not ignored, not replaced) and on the main thread.
    Returns the function restoring the previous handler.
    """
    import signal
    import sys
    import threading

    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.default_int_handler:
        return lambda: None

    from ..io.atomic import request_interrupt

    def on_sigint(signum, frame):
        request_interrupt()
        raise KeyboardInterrupt

    previous_hook = sys.unraisablehook

    def unraisable(info):  # the dropped interrupt is honoured through the record: no traceback for it
        if not isinstance(info.exc_value, KeyboardInterrupt):
            previous_hook(info)

    def restore():
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = previous_hook

    signal.signal(signal.SIGINT, on_sigint)
    sys.unraisablehook = unraisable
    return restore
