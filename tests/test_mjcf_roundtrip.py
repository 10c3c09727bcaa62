"""The MJCF round trip for every structure: export, edit as docs/mjcf.md says, run, diagnose.

For the BCC, the grid, every ``vlab init`` template and every file in examples/: the exported file
carries the plant's exact physics step (it reads back as the same double and divides the controller
period) and a ``vel<ID>`` sensor at every measured point, reading the velocity MuJoCo's own
``mj_objectVelocity`` gives there. Each documented edit is checked for the physics it claims, with
MuJoCo's API as the reference: an added body adds exactly its mass; the spring tendon is at its rest
length and pulls along ``w`` only (its Jacobian is the site's z row); ``gainprm`` scales the force
and leaves the sensor, while ``gear`` scales both. Through the command line (``export-mjcf`` ->
``experiment --mjcf`` -> ``diagnose``): the unedited file gives no mismatch, and each edit is named
by the diagnosis with its value (the shipped structures' runs are marked slow).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.design import PERIOD_S
from vlab.experiment.config import test_definition
from vlab.sim import build_plant, load_plant_for_experiment
from vlab.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))
runner = CliRunner()

#: Sources of the structures: shipped names, `vlab init` templates, example files (the `vlab init` copies of bcc
#: and grid export the shipped plants: tested below).
SOURCES = ["bcc", "grid", "init:beam", "init:frame"] + [f"example:{p.name}" for p in EXAMPLES]
#: Concealed values of the edits (added mass [kg], spring [N/m]) and the experiment's duration [s] (None: the test's).
#: The grid's 100 s: one 50-s record settles and one is measured.
EDIT_VALUES = {"bcc": (0.12, 200.0, 40.0), "grid": (0.12, 200.0, 100.0)}
DEFAULT_EDIT_VALUES = (0.03, 500.0, None)
GAIN = 1.3


def _cli(*args) -> str:
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res.stdout


def _structure(source: str, folder: Path) -> str:
    """A structure argument for the CLI: a shipped name, a fresh `vlab init` file or an example path."""
    kind, _, name = source.partition(":")
    if kind == "init" and name == "beam-along-x":
        return str(_beam_along_x(folder))
    if kind == "init":
        path = folder / f"{name}.toml"
        _cli("init", name, path)
        return str(path)
    if kind == "example":
        return str(ROOT / "examples" / name)
    return source


def _beam_along_x(folder: Path) -> Path:
    """The beam of `vlab init beam` turned to lie along x, its bending rotation ``ry`` (the template's comments
    say which rotation bends a member along x)."""
    along_y = folder / "along_y.toml"
    _cli("init", "beam", along_y)
    text = along_y.read_text()
    coords = re.search(r"coordinates = \{.*\}", text).group(0)
    turned = (text.replace(coords, re.sub(r"\[0, (\d+)\]", r"[\1, 0]", coords))
              .replace('dofs = ["w", "rx"]', 'dofs = ["w", "ry"]').replace('fixed = ["w", "rx"]', 'fixed = ["w", "ry"]'))
    assert turned.count('dofs = ["w", "ry"]') == 1 and turned.count('fixed = ["w", "ry"]') >= 1
    path = folder / "beam_along_x.toml"
    path.write_text(turned)
    return path


def _export(source: str, folder: Path) -> tuple[str, Path]:
    structure = _structure(source, folder)
    xml = folder / "plant.xml"
    _cli("export-mjcf", structure, "-o", xml)
    return structure, xml


def _points(spec) -> tuple[int, int]:
    """The edited point (the first measured point without a coil) and the edited coil (the excitation's)."""
    test, ins = test_definition(spec), spec.instrumentation
    free = [p for p in test.measured_points if p not in ins.actuators]
    return (free or [test.response_point])[0], ins.excitation


# ------------------------------------------------------------------------------------ the edits (docs/mjcf.md) ---


def add_mass(xml: str, point: int, mass: float) -> str:
    """A jointless body with ``mass`` [kg] beside the site ``p<point>`` (welded to the body carrying it)."""
    site = re.search(rf'<site name="p{point}"[^>]*/>', xml)
    assert site is not None, f"no site p{point}"
    body = f'<body name="mass{point}"><inertial pos="0 0 0" mass="{mass!r}" diaginertia="1e-6 1e-6 1e-6"/></body>'
    return xml[:site.end()] + body + xml[site.end():]


def add_spring(xml: str, point: int, xy: tuple[float, float], stiffness: float) -> str:
    """A spatial tendon of rest length 1 m from an anchor 1 m below point ``point`` (at ``xy`` [m]) to ``p<point>``."""
    x, y = xy
    xml = xml.replace("<worldbody>", f'<worldbody>\n    <site name="anchor{point}" pos="{x!r} {y!r} -1"/>', 1)
    tendon = (f'<tendon>\n    <spatial name="spring{point}" stiffness="{stiffness!r}" springlength="1">\n'
              f'      <site site="anchor{point}"/>\n      <site site="p{point}"/>\n    </spatial>\n  </tendon>')
    return xml.replace("</worldbody>", "</worldbody>\n  " + tendon, 1)


def set_actuator(xml: str, coil: int, attribute: str, value: str) -> str:
    """``attribute="value"`` on the actuator ``coil<coil>`` (``gainprm``; or ``gear``, replacing the written one)."""
    tag = re.search(rf'<general name="coil{coil}"[^>]*/>', xml)
    assert tag is not None, f"no actuator coil{coil}"
    text = re.sub(rf'\s{attribute}="[^"]*"', "", tag.group(0))
    text = text.replace(f'name="coil{coil}"', f'name="coil{coil}" {attribute}="{value}"')
    return xml[:tag.start()] + text + xml[tag.end():]


# --------------------------------------------------------------------------------------- the exported file ---


@pytest.fixture(scope="module")
def export_of(tmp_path_factory):
    """``export_of(source)`` -> (structure argument, exported file), each source exported once per module."""
    done: dict[str, tuple[str, Path]] = {}

    def get(source: str) -> tuple[str, Path]:
        if source not in done:
            done[source] = _export(source, tmp_path_factory.mktemp(re.sub(r"\W", "_", source)))
        return done[source]

    return get


@pytest.fixture(scope="module", params=SOURCES)
def exported(request, export_of):
    structure, xml = export_of(request.param)
    return request.param, load_spec(structure), xml


def _forward(model: mujoco.MjModel, seed: int = 0) -> mujoco.MjData:
    d = mujoco.MjData(model)
    d.qvel[:] = np.random.default_rng(seed).normal(size=model.nv)
    mujoco.mj_forward(model, d)
    return d


def test_the_file_keeps_the_exact_step_and_a_sensor_at_every_measured_point(exported):
    source, spec, xml = exported
    model = mujoco.MjModel.from_xml_path(str(xml))
    # the builder records its step at full precision in the header; the <option> must hold the same double
    header = re.search(r"timestep=([0-9.e+-]+),", xml.read_text())
    assert header is not None and model.opt.timestep == float(header.group(1)), source
    n_sub = round(PERIOD_S / model.opt.timestep)
    assert n_sub >= 1 and abs(n_sub * model.opt.timestep - PERIOD_S) <= 1e-12 * PERIOD_S, source
    test, ins = test_definition(spec), spec.instrumentation
    points = {*ins.actuators, *ins.sensors, *test.measured_points, test.response_point}
    d = _forward(model)
    for p in sorted(points - set(ins.actuators)):  # framelinvel sensors: the site's world z velocity
        v = np.zeros(6)
        mujoco.mj_objectVelocity(model, d, mujoco.mjtObj.mjOBJ_SITE, model.site(f"p{p}").id, v, 0)
        assert d.sensor(f"vel{p}").data[2] == pytest.approx(v[5], rel=1e-12, abs=1e-15), (source, p)
    for p in ins.actuators:
        assert model.sensor(f"vel{p}").type == mujoco.mjtSensor.mjSENS_ACTUATORVEL
    # the naming contract for an experiment that records the test's points
    load_plant_for_experiment(spec, mjcf=xml, sensors=test.measured_points)


def test_the_beam_template_s_step_is_the_plant_s(export_of):
    structure, xml = export_of("init:beam")
    h = build_plant(load_spec(structure)).timestep_s
    assert h == PERIOD_S / 12  # a step MuJoCo's six digits would round (4.16667e-05 does not divide 0.5 ms)
    assert mujoco.MjModel.from_xml_path(str(xml)).opt.timestep == h


def test_the_copies_written_by_vlab_init_export_the_shipped_plant(export_of):
    for name in ("bcc", "grid"):
        files = (export_of(name)[1], export_of(f"init:{name}")[1])
        body = [re.sub(r"<!--.*?-->", "", f.read_text()) for f in files]  # the header names the file
        assert body[0] == body[1], name


def test_each_documented_edit_has_its_physics(exported):
    source, spec, xml = exported
    text = xml.read_text()
    point, coil = _points(spec)
    nominal = mujoco.MjModel.from_xml_string(text)
    # an added body adds exactly its mass
    heavier = mujoco.MjModel.from_xml_string(add_mass(text, point, 0.05))
    assert heavier.body_subtreemass[0] == pytest.approx(nominal.body_subtreemass[0] + 0.05, abs=1e-12)
    assert heavier.body(f"mass{point}").parentid[0] == nominal.site(f"p{point}").bodyid[0]
    # the spring tendon: at its rest length (no pre-load) and along w only
    x, y = spec.points[point]
    sprung = mujoco.MjModel.from_xml_string(add_spring(text, point, (x, y), 500.0))
    d = _forward(sprung)
    t = sprung.tendon(f"spring{point}").id
    assert d.ten_length[t] == pytest.approx(1.0, abs=1e-6), source
    assert sprung.tendon_stiffness[t] == 500.0
    for seed in range(3):  # the tendon's rate of extension is the site's z velocity, whatever the motion
        d = _forward(sprung, seed)
        jacp = np.zeros((3, sprung.nv))
        mujoco.mj_jacSite(sprung, d, jacp, None, sprung.site(f"p{point}").id)
        assert d.ten_velocity[t] == pytest.approx(jacp[2] @ d.qvel, rel=1e-6), source  # the anchor is below
    # gainprm scales the force alone; gear scales the force and the collocated sensor
    results = {}
    for label, edited in (("nominal", text), ("gainprm", set_actuator(text, coil, "gainprm", "2")),
                          ("gear", set_actuator(text, coil, "gear", "0 0 2"))):
        m = mujoco.MjModel.from_xml_string(edited)
        d = mujoco.MjData(m)
        d.qvel[:] = np.random.default_rng(1).normal(size=m.nv)
        d.ctrl[m.actuator(f"coil{coil}").id] = 1.0
        mujoco.mj_forward(m, d)
        results[label] = (d.sensor(f"vel{coil}").data[0], d.qfrc_actuator.copy())
    (v0, f0), (v1, f1), (v2, f2) = results["nominal"], results["gainprm"], results["gear"]
    assert v0 != 0 and np.abs(f0).max() > 0
    assert v1 == pytest.approx(v0, rel=1e-12) and np.allclose(f1, 2 * f0, rtol=1e-12, atol=0)
    assert v2 == pytest.approx(2 * v0, rel=1e-12) and np.allclose(f2, 2 * f0, rtol=1e-12, atol=0)


# --------------------------------------------------------------------------- through the command line ---


def _diagnose(structure: str, xml: Path, folder: Path, duration: float | None) -> dict:
    exp = folder / "exp"
    _cli("experiment", structure, "--mjcf", xml, "--out", exp, *(["--duration", duration] if duration else []))
    return json.loads(_cli("diagnose", "--structure", structure, "--recording", exp / "recording.uff",
                           "--out", folder / "diagnosis", "--json"))


def test_the_unedited_file_runs_and_matches_its_structure(tmp_path):
    structure, xml = _export("init:beam", tmp_path)
    d = _diagnose(structure, xml, tmp_path, None)
    assert d["mismatch"] is False and not d["selected"], d["notes"]


#: Every structure with every edit; the shipped structures' runs (40 s and 100 s of the 2 kHz loop) are long
#: checks, the templates' and examples' (6-30 s each with the diagnosis) end-to-end checks (``slow``) but for one
#: edit of the smallest example, run by default. The beam template's and the beam along x's run here, the others in
#: test_mjcf_roundtrip_structures.py (two files, so that pytest-xdist's ``--dist loadfile`` runs them on two
#: workers); both call :func:`round_trip`.
DEFAULT_ROUND_TRIP = ("example:cantilever_tip_mass.toml", "mass")


def _marks(source: str, edit: str) -> list:
    if source in ("bcc", "grid"):
        return [pytest.mark.long]
    return [] if (source, edit) == DEFAULT_ROUND_TRIP else [pytest.mark.slow]


ROUND_TRIPS = [pytest.param(s, e, marks=_marks(s, e))
               for s in ("bcc", "grid", "init:beam", "init:frame", *(f"example:{p.name}" for p in EXAMPLES))
               for e in ("none", "mass", "spring", "gainprm")
               if (s, e) != ("init:beam", "none")]  # = test_the_unedited_file_runs_and_matches_its_structure
#: The beam along x (bending rotation ry) through design, experiment, export, edit and diagnose.
ROUND_TRIPS += [pytest.param("init:beam-along-x", e, marks=_marks("init:beam-along-x", e))
                for e in ("none", "mass", "gainprm")]
BEAM_SOURCES = ("init:beam", "init:beam-along-x")


@pytest.mark.parametrize(("source", "edit"), [p for p in ROUND_TRIPS if p.values[0] in BEAM_SOURCES])
def test_round_trip_names_the_edit(source, edit, tmp_path):
    round_trip(source, edit, tmp_path)


def round_trip(source: str, edit: str, tmp_path: Path) -> None:
    """Export ``source``, apply ``edit``, run the experiment on the edited file and diagnose it: no mismatch
    unedited, else the edit named first with its value."""
    structure, xml = _export(source, tmp_path)
    spec = load_spec(structure)
    point, coil = _points(spec)
    mass, stiffness, duration = EDIT_VALUES.get(source, DEFAULT_EDIT_VALUES)
    text = xml.read_text()
    edited = {"none": lambda: text, "mass": lambda: add_mass(text, point, mass),
              "spring": lambda: add_spring(text, point, spec.points[point], stiffness),
              "gainprm": lambda: set_actuator(text, coil, "gainprm", repr(GAIN))}[edit]()
    target = tmp_path / f"{edit}.xml"
    target.write_text(edited)
    d = _diagnose(structure, target, tmp_path, duration)
    if edit == "none":
        assert d["mismatch"] is False and not d["selected"], d["notes"]
        return
    assert d["mismatch"] is True
    first = d["selected"][0]
    effect, location, key, value, rel = {
        "mass": ("added_mass", {"point": point}, "mass_kg", mass, 0.05),
        "spring": ("support_stiffness", {"point": point, "dof": "w"}, "stiffness_n_per_m", stiffness, 0.05),
        "gainprm": ("actuator_gain", {"channel": coil}, "gain", GAIN, 0.01)}[edit]
    assert (first["effect"], first["location"]) == (effect, location), d["selected"]
    assert first["parameters"][key] == pytest.approx(value, rel=rel)


def test_the_beam_along_x_designs_as_the_beam_along_y(tmp_path):
    """`vlab design` of the beam turned along x (bending rotation ry), with the loop's margins: the same
    closed loop and gains as the template along y (a member along x through design)."""
    along_x = _beam_along_x(tmp_path)
    along_y = tmp_path / "along_y.toml"  # written by _beam_along_x
    x, y = (json.loads(_cli("design", p, "--margins", "--format", "json")) for p in (along_x, along_y))
    assert np.allclose(x["frequencies_hz"], y["frequencies_hz"], rtol=1e-9)
    assert np.allclose(x["gain_n_s_per_m"], y["gain_n_s_per_m"], rtol=1e-6)
    assert x["loop"]["nyquist"] == y["loop"]["nyquist"]
    assert x["loop"]["peak_sensitivity"] == pytest.approx(y["loop"]["peak_sensitivity"], rel=1e-6)
