"""Command line: ``python -m benchmarks.reference_sim --structure bcc --case C --out DIR``.

Writes ``recording.uff`` (compat mode: velocities at the controller rate, the
channels today's vlab readers take), ``lab.uff`` (lab mode: accelerations and force
at 5 kHz, 16 bit) and ``truth.json`` (the concealed effects and settings). A
closed-loop case needs the controller's gains: ``--design FILE`` (``vlab design bcc
--controller mfdrf --json``) or, without it, the command runs that ``vlab design``
as a separate program and keeps its output as ``design.json``. The simulator
itself never imports vlab.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

from .cases import CaseError, load_case
from .loop import Controller, ControllerError
from .run import simulate, write_outputs


def _controller(case, design, out: Path) -> Controller:
    if case.controller == "none":
        return Controller.zero(3)
    path = design or case.design
    if path is None:
        exe = shutil.which("vlab")
        if exe is None:
            raise ControllerError("closed-loop case without --design and no vlab command")
        text = subprocess.run([exe, "design", "bcc", "--controller", case.controller, "--json"],
                              check=True, capture_output=True, text=True).stdout
        path = out / "design.json"
        path.write_text(text)
    return Controller.from_design_json(path)


def main(argv=None) -> int:
    """Run the command; return the exit status (0 ok, 2 bad input)."""
    ap = argparse.ArgumentParser(prog="python -m benchmarks.reference_sim",
                                 description="Record a BCC test with the independent reference simulator.")
    ap.add_argument("--structure", default="bcc", choices=["bcc"], help="structure (only bcc)")
    ap.add_argument("--case", required=True, help="case description (.json or .toml)")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--design", help="controller design JSON (vlab design ... --json)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    try:
        case = load_case(args.case)
        out.mkdir(parents=True, exist_ok=True)
        ctrl = _controller(case, args.design, out)
    except (CaseError, ControllerError, OSError, ValueError, subprocess.CalledProcessError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    result = simulate(case, ctrl)
    files = write_outputs(result, out)
    print(f"simulated {result['truth']['excitation']['period_s']} s x "
          f"{case.excitation['settle_periods'] + case.excitation['periods']} periods "
          f"in {time.perf_counter() - t0:.1f} s; wrote " + ", ".join(str(f) for f in files))
    return 0


if __name__ == "__main__":
    sys.exit(main())
