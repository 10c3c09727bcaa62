"""`vlab reproduce` piped or redirected: one line per step, with the simulations' time left once one ran."""

from __future__ import annotations

from vlab.reproduce.run import _Bars


def test_piped_progress_prints_a_line_per_step_and_the_time_left(capsys):
    with _Bars(True) as bars:  # pytest's stderr is not a terminal: lines, no rich bars
        bars.start(3, 100.0)
        _cb, done = bars.sub("bcc/none (50 s simulated)", 50.0)
        done()
        bars.step("bcc/none")
        _cb, done = bars.sub("bcc/mfdrf (50 s simulated)", 50.0)
        done()
        bars.step("bcc/mfdrf")
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("reproduce: 3 steps, at least 100 s simulated in all")
    assert lines[1].startswith("reproduce: bcc/none (50 s simulated) ...")
    assert lines[2].startswith("reproduce: 1 of 3 steps done (bcc/none); the simulations left: about ")
    assert lines[4].startswith("reproduce: 2 of 3 steps done (bcc/mfdrf)") and "left" not in lines[4]


def test_no_progress_prints_nothing(capsys):
    with _Bars(None) as bars:
        bars.start(2, 10.0)
        _cb, done = bars.sub("x", 10.0)
        done()
        bars.step("x")
    assert capsys.readouterr().err == ""
