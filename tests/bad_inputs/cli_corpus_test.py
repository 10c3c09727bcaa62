"""The CLI bad-input corpus: every case is refused cleanly, before any work, changing nothing.

Each case of ``cli_cases.json`` runs ``vlab <args>`` in-process (typer's
CliRunner) in a fresh temporary folder and checks, independently of vlab:

- the exit status (2 = bad input);
- that the offending option, value or path appears in the output (whitespace
  and rich's box characters normalised);
- that no traceback is printed and no exception escapes;
- that no work started: the functions that simulate, design, reproduce,
  diagnose or export are replaced by a trap that fails the case, and a
  20 s alarm fails a case that hangs;
- that no file or folder of the temporary folder changed (SHA-256 of every
  file, and the set of paths, before and after).
"""

from __future__ import annotations

import hashlib
import json
import re
import signal
from pathlib import Path

import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.io.manifest import write_manifest
from vlab.spec import STRUCTURES_DIR as STRUCTURES
from vlab.spec import load_spec

CASES = json.loads((Path(__file__).parent / "cli_cases.json").read_text())["cases"]


def _import_every_module() -> None:
    """Import every module of vlab now, before any trap is set: a module imported for the first time while a
    trap replaces ``vlab.sim.build_plant`` would bind the trap by ``from ..sim import build_plant`` for the
    rest of the test session."""
    import importlib
    import pkgutil

    import vlab

    for m in pkgutil.walk_packages(vlab.__path__, "vlab."):
        importlib.import_module(m.name)


_import_every_module()


class StartedWork(BaseException):
    """Raised by the traps: a refused case must not reach the work (BaseException: no handler catches it)."""


class TimedOut(BaseException):
    """Raised by the per-case alarm."""


def _trap(name):
    def trap(*args, **kwargs):
        raise StartedWork(f"{name} was called: the case started work before refusing")
    return trap


def _populate(root: Path) -> None:
    (root / "existing_dir").mkdir()
    (root / "existing_dir" / "inner_file.txt").write_text("keep me\n")
    (root / "empty_dir").mkdir()
    (root / "folder.xml").mkdir()
    (root / "existing.xml").write_text("<mujoco/>\n")
    (root / "existing_file.txt").write_text("precious\n")
    (root / "rec.uff").write_text("    -1\n    58\n")
    (root / "model.xml").write_text("<mujoco/>\n")
    # an output folder vlab did not write, holding a file named like one of vlab's outputs
    (root / "notvlab").mkdir()
    (root / "notvlab" / "results.json").write_text("{}\n")
    (root / "notvlab" / "thesis.tex").write_text("\\documentclass{book}\n")
    # a folder vlab wrote, to which the user added a file, and one whose listed file the user edited
    for name, extra in (("vlab_plus_foreign", "thesis.tex"), ("vlab_edited", None)):
        (root / name).mkdir()
        (root / name / "results.json").write_text('{"structure": "bcc"}\n')
        write_manifest(root / name)
        if extra:
            (root / name / extra).write_text("mine\n")
        else:
            (root / name / "results.json").write_text('{"structure": "bcc", "my_note": 1}\n')
    (root / "link_to_dir").symlink_to("existing_dir")
    bcc = (STRUCTURES / "bcc.toml").read_text()
    ref = 'frequencies = "table1_bcc_frequencies.csv"'
    assert ref in bcc
    for name, target in (("escape_abs.toml", "/etc/passwd"), ("escape_rel.toml", "../" * 12 + "etc/passwd"),
                         ("escape_dev.toml", "/dev/zero"), ("escape_hostname.toml", "/etc/hostname")):
        (root / name).write_text(bcc.replace(ref, f'frequencies = "{target}"'))
    points = load_spec("bcc").points
    (root / "all_clamped.toml").write_text(bcc + "".join(
        f'\n[[supports]]\npoint = {k}\nfixed = ["w"]\ninplane = "free"\n' for k in points))
    (root / "huge_member.toml").write_text(_long_beam(10000))   # a member through 10 000 points
    (root / "deep_chain.toml").write_text(_long_beam(1100))     # a plant deeper than MuJoCo compiles
    from vlab.templates import template_text

    (root / "with_hardware.toml").write_text(template_text("beam") + '\n[[hardware.sensor_gain]]\nchannel = 5\n'
                                             'gain = 0.9\nsource = "a calibration"\n')
    (root / "include_abs.xml").write_text('<mujoco><include file="/etc/passwd"/></mujoco>\n')
    (root / "include_rel.xml").write_text(f'<mujoco><include file="{"../" * 12}etc/hostname"/></mujoco>\n')


def _long_beam(n: int) -> str:
    """``vlab init beam``'s structure with its strip through ``n`` points 0.1 mm apart (coils at 5 and ``n``)."""
    from vlab.templates import template_text

    text = template_text("beam")
    coords = ", ".join(f"{i} = [0, {0.1 * (i - 1):.1f}]" for i in range(1, n + 1))
    text = re.sub(r"coordinates = \{.*\}", "coordinates = { " + coords + " }", text)
    text = text.replace("points = [1, 2, 3, 4, 5, 6, 7, 8, 9]", f"points = {list(range(1, n + 1))}")
    for old, new in (("point = 9\n", f"point = {n}\n"), ("actuators = [9, 5]", f"actuators = [{n}, 5]"),
                     ("sensors = [9, 5, 7]", f"sensors = [{n}, 5, 7]"), ("excitation = 9 ", f"excitation = {n} "),
                     ("measured_points = [3, 5, 7, 9]", f"measured_points = [3, 5, 7, {n}]")):
        assert old in text, old
        text = text.replace(old, new)
    return text


def _snapshot(root: Path) -> dict[str, str]:
    out = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        out[rel] = (f"link:{p.readlink()}" if p.is_symlink() else
                    hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir")
    return out


def _normalise(text: str) -> str:
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", text).split())


def test_corpus_is_large_and_unique():
    ids = [c["id"] for c in CASES]
    assert len(CASES) >= 90 and len(set(ids)) == len(ids)
    assert {c["args"][0] for c in CASES} >= {"modes", "design", "experiment", "export-mjcf", "reproduce",
                                              "diagnose", "crosscheck"}


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_cli_bad_input(case, tmp_path, monkeypatch):
    import vlab.design
    import vlab.diagnose
    import vlab.experiment.runner
    import vlab.reproduce
    import vlab.sim

    for mod, name in ((vlab.experiment.runner, "run_experiment"), (vlab.design, "design_controller"),
                      (vlab.reproduce, "reproduce"), (vlab.diagnose, "diagnose"), (vlab.sim, "export_mjcf"),
                      (vlab.sim, "build_plant")):
        monkeypatch.setattr(mod, name, _trap(f"{mod.__name__}.{name}"))
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.chdir(tmp_path)
    _populate(tmp_path)
    before = _snapshot(tmp_path)

    def alarm(signum, frame):
        raise TimedOut(f"case {case['id']} ran over 20 s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(20)
    try:
        res = CliRunner().invoke(app, case["args"])
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    out = res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), (
        f"{type(res.exception).__name__}: {res.exception}\n{out}")
    assert res.exit_code == case["exit_code"], out
    assert "Traceback" not in out, out
    assert _normalise(case["message_contains"]) in _normalise(out), out
    assert len(out.strip().splitlines()) <= 10, out  # one error line (typer usage errors: a small box)
    assert _snapshot(tmp_path) == before
