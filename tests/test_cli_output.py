"""Readable CLI output: help of every option, no <bool>, no lqr for experiment, full width
when piped, the diagnose table and verdict with units."""

from __future__ import annotations

import re
from types import SimpleNamespace

import pytest
import typer.main
from typer.testing import CliRunner

from vlab.cli import app

COMMANDS = ("modes", "design", "experiment", "crosscheck", "export-mjcf", "reproduce", "diagnose", "update")


def _group():
    return typer.main.get_command(app)


def _help(args, width=100):
    res = CliRunner().invoke(app, [*args, "--help"], terminal_width=width)
    assert res.exit_code == 0, res.output
    return res.output


@pytest.mark.parametrize("command", COMMANDS)
def test_every_option_says_what_it_is_and_its_default(command):
    group = _group()
    cmd = group.commands[command]
    for p in cmd.params:
        if p.name == "help":
            continue
        text = (p.help or "").strip()
        assert len(text) >= 10, f"{command} {p.name}: no help"
        is_flag = getattr(p, "is_flag", False)
        shown_by_typer = (not is_flag and p.default is not None and p.show_default is not False
                          and not p.required)
        assert p.required or shown_by_typer or "default" in text, f"{command} {p.name}: default not named"


@pytest.mark.parametrize("command", ("", *COMMANDS))
def test_help_shows_no_bool_metavar_and_no_eaten_units(command):
    out = _help([command] if command else [])
    assert "<bool>" not in out
    if command == "experiment":
        flat = " ".join(re.sub(r"[│╭╮╰╯─]", " ", out).split())
        for unit in ("[s]", "[ms]", "[m/s]", "[sampling periods]"):  # rich markup used to eat these
            assert unit in flat, unit


def test_experiment_does_not_offer_lqr():
    out = _help(["experiment"], width=200)
    choices = re.search(r"--controller\s+<([^>]*)>", out).group(1)
    assert "lqr" not in choices.split("|") and "mfdrf" in choices.split("|")
    res = CliRunner().invoke(app, ["experiment", "--controller", "lqr", "--plant", "linear"])
    assert res.exit_code == 2 and "lqr" in res.output


def test_the_delay_option_is_delay_periods_and_its_former_name_a_hidden_alias():
    out = _help(["experiment"], width=200)
    assert "--delay-periods" in out and "--delay-samples" not in out
    for name in ("--delay-periods", "--delay-samples"):
        res = CliRunner().invoke(app, ["experiment", "--plant", "linear", "--controller", "none", name, "-1"])
        assert res.exit_code == 2 and "--delay-periods must be >= 0" in " ".join(res.output.split()), res.output


@pytest.mark.parametrize("command", ("", *typer.main.get_command(app).commands))
def test_help_names_no_issue_and_no_file_of_the_repository(command):
    out = " ".join(re.sub(r"[│╭╮╰╯─]", " ", _help([command] if command else [], width=200)).split())
    assert not re.search(r"\bissue \d", out) and "docs/" not in out, out


def _rows_ok(output: str, needles) -> None:
    assert "…" not in output
    lines = output.splitlines()
    for needle in needles:
        hits = [ln for ln in lines if needle in ln]
        assert hits, (needle, output)
        # one line per row: the row's cell text is whole on one line, framed by the table's borders
        assert hits[0].lstrip()[:1] in "│┃" and hits[0].rstrip()[-1:] in "│┃", hits[0]


def test_piped_tables_use_the_full_width(monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)
    res = CliRunner().invoke(app, ["modes", "bcc", "--n", "3"])
    assert res.exit_code == 0, res.output
    # the title and header are each on one line (at 80 columns the title wrapped)
    assert "Beam Cross-Cable: natural frequencies (full model) vs" in res.output
    _rows_ok(res.output, ["thesis experimental [Hz]"])


def _fake_result():
    """A diagnosis result as ``as_dict`` gives it (two effects, a pair location, SI names with unit suffixes)."""
    ranked = [
        {"effect": "added_mass", "location": {"point": 6}, "parameters": {"mass_kg": 0.1180},
         "ci95": {"mass_kg": [0.1043, 0.1312]}, "score": 176.1, "aic": 171.2, "chi2": 169.2, "delta_bic": 1.29e6,
         "misfit_before": 0.0674, "misfit_after": 0.000743},
        {"effect": "member_stiffness", "location": {"member": "beam", "segment": [4, 5]},
         "parameters": {"ei_n_m2": 20.27}, "ci95": {"ei_n_m2": [20.05, 20.50]}, "score": 418490.7,
         "aic": 1.0, "chi2": 418483.8, "delta_bic": 8.7e5, "misfit_before": 0.0674, "misfit_after": 0.0403},
        {"effect": "sensor_gain", "location": {"channel": 9}, "parameters": {"gain": 1.31},
         "ci95": {"gain": [1.2, 1.4]}, "score": 500000.0, "aic": 1.0, "chi2": 1.0, "delta_bic": 1.0,
         "misfit_before": 0.0674, "misfit_after": 0.05},
    ]
    d = {"structure": "bcc", "controller": "mfdrf", "mismatch": True,
         "data": {"source": "rec.uff", "kind": "recording"},
         "statistics": {"chi2_nominal": 1.291e6, "chi2_limit": 1352.0, "n_obs": 984},
         "ranked": ranked, "alternatives": [],
         "selected": [{k: ranked[0][k] for k in ("effect", "location", "parameters", "ci95")}],
         "validated": {"plant": "linear FE plant", "misfit_before": 0.0675, "misfit_after": 0.000725,
                       "noise_misfit": 0.000835}}
    return SimpleNamespace(as_dict=lambda: d, files={})


def test_diagnose_prints_a_table_with_units_and_a_verdict(tmp_path, monkeypatch):
    import vlab.diagnose

    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.setattr(vlab.diagnose, "diagnose", lambda *a, **k: _fake_result())
    rec = tmp_path / "rec.uff"
    rec.write_text("x")
    res = CliRunner().invoke(app, ["diagnose", "--structure", "bcc", "--recording", str(rec), "--controller",
                                   "mfdrf", "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    out = res.output
    assert "{" not in out and "'" not in out.replace("model's", "")  # no raw Python dicts
    _rows_ok(out, ["0.118 kg [0.104, 0.131]", "beam 4-5", "20.3 N m^2 [20.1, 20.5]", "channel 9",
                   "dBIC to the best", "misfit after [decades]"])
    row1 = next(ln for ln in out.splitlines() if "added_mass" in ln)
    assert "point 6" in row1 and "0.000743" in row1 and re.search(r"│\s+0\s+│", row1), row1
    row2 = next(ln for ln in out.splitlines() if "member_stiffness" in ln)
    assert "4.183e+05" in row2  # 418490.7 - 176.1, the BIC difference to the best
    flat = " ".join(out.split())
    assert "Mismatch:" in flat and "Selected: added_mass at point 6 (mass 0.118 kg [0.104, 0.131])" in flat
    assert "93.1 x lower" in flat  # 0.0675 / 0.000725


def test_verdict_without_a_mismatch_and_a_higher_misfit():
    from vlab.diagnose.report.text import format_location, format_parameter
    from vlab.diagnose.report.verdict import verdict

    d = _fake_result().as_dict()
    assert "No significant mismatch" in verdict(dict(d, mismatch=False))
    worse = dict(d, validated=dict(d["validated"], misfit_after=0.135))
    assert "2 x higher" in verdict(worse)
    assert format_location({"first": {"point": 6}, "second": {"channel": "all"}}) == "point 6 + all channels"
    assert format_parameter("c_n_s_per_m", 2.5, [2.0, 3.0]) == "2.5 N s/m [2, 3]"
    assert format_parameter("damping_ratio", 0.02, None) == "0.02"


def test_unbounded_interval_is_said_not_printed():
    """A log-scaled parameter the data do not bound gets no interval like [7.55e-145, 1.13e+135]."""
    import numpy as np

    from vlab.diagnose.fit.estimate import UNBOUNDED_DECADES, ci95_of
    from vlab.diagnose.report.text import format_parameter

    jac = np.array([[1.0, 1e-9], [0.0, 1e-9], [1.0, 0.0]])  # the second (log) parameter barely moves the residuals
    ci = ci95_of(jac, np.array([0.5, -4.5]), chi2=3.0, n=3, log=(False, True))
    assert np.all(np.isfinite(ci[0])) and np.all(np.isnan(ci[1]))
    well = ci95_of(np.array([[10.0], [10.0]]), np.array([-1.0]), chi2=2.0, n=2, log=(True,))
    assert np.all(np.isfinite(well)) and np.log10(well[0, 1] / well[0, 0]) < 2 * UNBOUNDED_DECADES
    assert format_parameter("c_n_s_m", 3e-5, [None, None]).endswith("[not bounded by the data]")
    assert format_parameter("c_n_s_m", 3e-5, [float("nan"), float("nan")]).endswith("[not bounded by the data]")
    assert format_parameter("mass_kg", 0.1182, [0.1179, 0.1184]) == "0.1182 kg [0.1179, 0.1184]"


def test_stages_are_one_line_each_when_piped_and_nothing_when_quiet(capsys):
    """A long command shows where it is: piped stderr gets one line per stage with the elapsed time."""
    from vlab.cli.output import err_console, stages

    assert not err_console.is_terminal  # pytest captures stderr
    with stages("diagnose", "reading the recording") as say:
        say("fitting")
    err = capsys.readouterr().err.splitlines()
    assert [e.rsplit(" (", 1)[0] for e in err] == ["diagnose: reading the recording", "diagnose: fitting"]
    assert all(e.endswith(" s)") for e in err)
    with stages("diagnose", "reading the recording", quiet=True) as say:
        say("fitting")
    assert capsys.readouterr().err == ""
