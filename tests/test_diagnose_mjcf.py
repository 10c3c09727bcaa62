"""`vlab diagnose --mjcf FILE`: the nominal plant given as an MJCF file is the reference.

A recording made on an edited plant (0.12 kg added beside point 6, as the tutorial does it) is diagnosed
with that same file as the nominal plant: the recording and its replay then differ only by the noise,
so there is no mismatch -- while against the plant built from the spec the mass is found (the README's
example). Bad uses are refused naming the option and the file.
"""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from vlab.cli import app

runner = CliRunner()

MASS6 = '<body name="mass6"><inertial pos="0 0 0" mass="0.12" diaginertia="1e-6 1e-6 1e-6"/></body>'


@pytest.fixture(scope="module")
def mass6(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mjcf")
    nominal = tmp / "bcc.xml"
    res = runner.invoke(app, ["export-mjcf", "bcc", "-o", str(nominal)])
    assert res.exit_code == 0, res.output
    site = '<site name="p6" size="0.004" group="3"/>'
    text = nominal.read_text()
    assert text.count(site) == 1
    edited = tmp / "bcc_mass6.xml"
    edited.write_text(text.replace(site, site + MASS6))
    exp = tmp / "exp"
    res = runner.invoke(app, ["experiment", "--mjcf", str(edited), "--out", str(exp)])
    assert res.exit_code == 0, res.output
    return tmp, nominal, edited, exp / "recording.uff"


def _diagnose(rec, mjcf, out, *options):
    """``vlab diagnose`` of the BCC recording ``rec`` against the nominal plant file ``mjcf``, into ``out``."""
    return runner.invoke(app, ["diagnose", "--structure", "bcc", "--recording", str(rec), "--mjcf", str(mjcf),
                               *options, "--out", str(out)])


def _diagnose_json(rec, mjcf, out):
    """:func:`_diagnose` with ``--json``, which must succeed: the JSON printed."""
    res = _diagnose(rec, mjcf, out, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


@pytest.mark.slow
def test_the_recordings_own_plant_as_nominal_leaves_no_mismatch(mass6):
    tmp, _nominal, edited, rec = mass6
    d = _diagnose_json(rec, edited, tmp / "d1")
    assert d["mismatch"] is False, d["notes"]
    assert str(edited) in d["reference"]
    assert any("the nominal plant is" in n for n in d["notes"])


def test_mjcf_with_the_linear_plant_is_refused(mass6):
    tmp, nominal, _edited, rec = mass6
    res = _diagnose(rec, nominal, tmp / "d2", "--plant", "linear", "--force")
    assert res.exit_code == 2
    assert "--mjcf" in res.output and "linear" in res.output


def test_an_mjcf_that_breaks_the_naming_contract_is_named(mass6):
    tmp, nominal, _edited, rec = mass6
    broken = tmp / "no_coil5.xml"
    text = nominal.read_text()
    assert 'name="coil5"' in text
    broken.write_text(text.replace('name="coil5"', 'name="motor5"'))
    res = _diagnose(rec, broken, tmp / "d3")
    assert res.exit_code == 2
    assert "no_coil5.xml" in res.output and "coil5" in res.output


@pytest.mark.slow
def test_a_structural_effect_against_an_mjcf_nominal_is_validated_on_the_spec_plant(mass6):
    tmp, nominal, _edited, rec = mass6
    d = _diagnose_json(rec, nominal, tmp / "d4")
    assert d["mismatch"] is True
    (sel,) = d["selected"]
    assert sel["effect"] == "added_mass" and sel["location"] == {"point": 6}
    assert sel["parameters"]["mass_kg"] == pytest.approx(0.12, rel=0.05)
    # the unchanged export is the reference; the mass cannot be put into the file, so both validation reruns
    # run on the plant built from the spec
    assert str(nominal) in d["reference"]
    assert "built from the spec" in d["validated"]["plant"]
    assert d["validated"]["misfit_after"] < d["validated"]["misfit_before"] / 5
