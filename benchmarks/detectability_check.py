"""Check the detection thresholds of ``vlab detectability`` against the diagnosis itself.

For effects of the library on the BCC (open loop, or ``--controller``), the threshold is computed
(:func:`vlab.diagnose.detectability.detectability`); then recordings are made on the linear FE plant in the
2 kHz loop with the effect concealed at 0.5x and at 3x its threshold (the distance from the null value
scaled), each with its own seed of excitation and sensor noise (seeds not used by the threshold
computation), and diagnosed blind (:func:`vlab.diagnose`). Printed: per effect and factor, how often the
diagnosis says "no significant mismatch" (expected at 0.5x) and how often it names the effect at its
location (expected at 3x). The targets: >= 80 % "no mismatch" at 0.5x, >= 90 % named at 3x.
The naming threshold (:mod:`vlab.diagnose.naming`, every one-parameter effect of the library a
look-alike) is checked the same way: recordings at 2x it, the effect expected named.
The recordings come from the FE model's own linear plant in the time domain: the check tests the
thresholds against the test they predict, not on another fidelity (the MuJoCo plant is not checked).

Usage: python benchmarks/detectability_check.py [--seeds 2] [--controller none] [--out FILE]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import vlab
from vlab.diagnose.data.replay import linear_plant
from vlab.diagnose.detectability import detectability, nominal_test
from vlab.diagnose.effects.hypotheses import library
from vlab.io.uff import write_recording
from vlab.experiment.config import ExperimentConfig
from vlab.experiment.runner import measure

#: (effect, location) pairs checked: structural and controller-path, chosen before any run.
CASES = (("added_mass", {"point": 6}), ("added_mass", {"point": 2}), ("support_stiffness", {"point": 5, "dof": "w"}),
         ("joint_flexibility", {"point": 7}), ("member_stiffness", {"member": "beam", "segment": [4, 5]}),
         ("damping", {"mode": 3}), ("actuator_gain", {"channel": 9}), ("actuator_lag", {"channel": "all"}))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2, help="recordings per effect and factor")
    ap.add_argument("--controller", default="none")
    ap.add_argument("--out", default=None, help="also write the listing to this file")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    effects = tuple(sorted({e for e, _ in CASES}))
    det = detectability("bcc", a.controller, effects=effects, model_form="none",  # recorded by the model itself
                        naming=True)
    spec, nominal, _data, ctx = nominal_test("bcc", a.controller)
    chain, design = nominal.chain, nominal.design
    hyps = library(nominal, ctx, effects=effects)
    meta = {"structure": "bcc", "controller": a.controller, "reduction": None, "excitation": "random", "seed": 0,
            "plant": "linear FE model", "chain": {"delay_periods": chain.delay_periods, "filter_hz": chain.filter_hz,
                                                  "amplifier_gain": 1.0, "amplifier_limit_n": None}}
    lines = [f"$ python benchmarks/detectability_check.py --seeds {a.seeds} --controller {a.controller}",
             f"BCC, {a.controller}, linear FE plant, sensor noise 1e-6 m/s; chi2 limit {det.chi2_limit:.4g}, "
             f"N = {det.n_obs}", "",
             f"{'effect':<20} {'location':<34} {'threshold':>12} {'by':>5}   0.5x: no mismatch   3x: named right"
             f"   {'naming threshold':>16}   2x naming: named right"]
    quiet, named, n_half, n_three, named2, n_two = 0, 0, 0, 0, 0, 0
    with tempfile.TemporaryDirectory() as tmp:
        for eff, loc in CASES:
            th = [t for t in det.of(eff, loc) if t.threshold is not None]
            if not th:
                lines.append(f"{eff:<20} {str(loc):<34} {'not detected':>12}")
                continue
            t = min(th, key=lambda t: abs(t.scaled(1.0) - t.scaled(2.0)))  # the side found at the smaller change
            (h,) = [x for x in hyps if x.effect == eff and x.location == loc]
            res = {}
            sizes = {0.5: t.scaled(0.5), 3.0: t.scaled(3.0)}
            if t.named_at is not None:
                sizes["naming"] = replace(t, threshold=t.named_at).scaled(2.0)
            for factor, size in sizes.items():
                ok = 0
                for k in range(a.seeds):
                    seed = 1000 + k
                    state = h.apply(nominal, np.array([size]), ctx)
                    cfg = ExperimentConfig(structure="bcc", controller=a.controller, plant="linear",
                                           chain=replace(state.chain, noise_m_s=1e-6), seed=seed)
                    # the plant of the state (a mode's damping lives in its spec, a dashpot in the state: the
                    # plant measure() builds from the FE model alone would miss them)
                    rec = measure(cfg, state.fe, design, metadata=meta,
                                  plant=(linear_plant(state), {"kind": "linear FE model"})).loop.recording
                    path = Path(tmp) / f"{eff}_{factor}_{k}.uff"
                    write_recording(path, rec, overwrite=True)
                    d = vlab.diagnose(spec, path).as_dict()
                    if factor == 0.5:
                        ok += not d["mismatch"]
                    else:
                        ok += any(s["effect"] == eff and s["location"] == loc for s in d["selected"])
                res[factor] = ok
            quiet += res[0.5]
            named += res[3.0]
            n_half += a.seeds
            n_three += a.seeds
            if "naming" in res:
                named2 += res["naming"]
                n_two += a.seeds
            lines.append(f"{eff:<20} {str(loc):<34} {t.threshold:>12.4g} {t.by or '':>5}   "
                         f"{res[0.5]}/{a.seeds}{'':>15} {res[3.0]}/{a.seeds}{'':>13}"
                         + (f"{t.named_at:>16.4g}   {res['naming']}/{a.seeds}" if "naming" in res else
                            f"{'not named':>16}   -"))
            print(lines[-1], flush=True)
    lines += ["", f"0.5x threshold: no mismatch in {quiet}/{n_half} ({100 * quiet / max(n_half, 1):.0f} %, target >= 80 %)",
              f"3x threshold: the effect named at its location in {named}/{n_three} "
              f"({100 * named / max(n_three, 1):.0f} %, target >= 90 %)",
              f"2x naming threshold: the effect named at its location in {named2}/{n_two} "
              f"({100 * named2 / max(n_two, 1):.0f} %)",
              f"time {time.perf_counter() - t0:.0f} s"]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    if a.out:
        Path(a.out).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
