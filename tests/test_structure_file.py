"""Structure files of one's own: `vlab init`, the [test] and [design] tables, the
structure argument of every command (a name or a .toml path; a clear error, exit 2)."""

from __future__ import annotations

import re
import tomllib

import pytest
from typer.testing import CliRunner

from vlab.cli import app
from vlab.design import THESIS_SETTINGS, design_settings
from vlab.errors import SpecError
from vlab.experiment.config import TESTS, test_definition
from vlab.spec import STRUCTURES_DIR, load_spec, spec_from_dict

runner = CliRunner()


@pytest.mark.parametrize("kind", ["beam", "frame", "bcc", "grid"])
def test_init_writes_a_template_that_loads_and_refuses_to_overwrite(tmp_path, kind):
    from vlab.fe import build_fe_model
    from vlab.models import check_fe_model

    path = tmp_path / f"my_{kind}.toml"
    res = runner.invoke(app, ["init", kind, str(path)])
    assert res.exit_code == 0, res.output
    spec = load_spec(path)
    check_fe_model(build_fe_model(spec))  # a held structure whose modes double precision resolves
    assert spec.test is not None and spec.instrumentation is not None
    assert test_definition(spec) == spec.test
    text = path.read_text()
    assert text.lstrip().startswith("#")  # commented
    path.write_text(text + "# edited\n")
    res = runner.invoke(app, ["init", kind, str(path)])
    assert res.exit_code == 2 and "--overwrite" in res.output
    assert path.read_text().endswith("# edited\n")  # untouched
    assert runner.invoke(app, ["init", kind, str(path), "--overwrite"]).exit_code == 0
    assert not path.read_text().endswith("# edited\n")


@pytest.mark.parametrize("name", ["bcc", "grid"])
def test_a_renamed_copy_of_a_shipped_structure_keeps_its_test_and_design(tmp_path, name):
    path = tmp_path / "copy.toml"
    assert runner.invoke(app, ["init", name, str(path)]).exit_code == 0
    path.write_text(re.sub(rf'name = "{name}"', 'name = "my_copy"', path.read_text(), count=1))
    spec = load_spec(path)
    assert spec.name == "my_copy"
    assert test_definition(spec) == TESTS[name]
    st = design_settings(spec)
    ref = THESIS_SETTINGS[name]
    for field in ("zeta_min", "n_modes", "n_f", "q_scale", "r", "v1", "v2", "alpha", "r_corrected"):
        assert getattr(st, field) == getattr(ref, field), field


def test_init_refuses_an_unknown_kind_and_a_wrong_suffix(tmp_path):
    res = runner.invoke(app, ["init", "tower", str(tmp_path / "t.toml")])
    assert res.exit_code == 2
    res = runner.invoke(app, ["init", "beam", str(tmp_path / "t.txt")])
    assert res.exit_code == 2 and ".toml" in res.output and not (tmp_path / "t.txt").exists()


def _doc(kind="beam"):
    from vlab.templates import template_text

    return tomllib.loads(template_text(kind))


def test_shipped_structures_keep_their_tests_without_a_test_table():
    for name in ("bcc", "grid"):
        spec = load_spec(name)
        assert spec.test is None and test_definition(spec) is TESTS[name]
        assert test_definition(name) is TESTS[name]


def test_a_structure_without_test_table_is_refused_naming_the_file(tmp_path):
    doc = _doc()
    del doc["test"]
    spec = spec_from_dict(doc, path=tmp_path / "no_test.toml")
    with pytest.raises(SpecError, match=r"no_test\.toml.*no \[test\] table"):
        test_definition(spec)


@pytest.mark.parametrize("field, value, message", [
    ("band_hz", [10.0, 5.0], "0 <= low < high"),
    ("band_hz", [1.0, 900.0], "250"),
    ("resolution_hz", 0.0, "must lie in"),
    ("resolution_hz", 40.0, "fewer than 4 lines"),
    ("rms_n", -1.0, "must lie in"),
    ("n_modes", 0, ">= 1"),
    ("response_point", 99, "unknown point id 99"),
    ("response_point", 2, "neither measured"),
    ("measured_points", [3, 3], "repeated"),
    ("response_quantity", "acceleration", "not one of"),
    ("bandwidth", 3, "unknown field"),
])
def test_bad_test_table_values_name_the_field(field, value, message):
    doc = _doc()
    doc["test"][field] = value
    if field == "response_point" and value == 2:
        doc["test"]["measured_points"] = [3, 7]
    with pytest.raises(SpecError, match=rf"field 'test\.{field}'.*{re.escape(message)}"):
        spec_from_dict(doc)


@pytest.mark.parametrize("field, value, message", [
    ("zeta_min", 1.0, "must lie in"),
    ("n_modes", 0, ">= 1"),
    ("r", 0.0, "must lie in"),
    ("default_model", "modal", "not one of"),
    ("weights", 1.0, "unknown field"),
])
def test_bad_design_table_values_name_the_field(field, value, message):
    doc = _doc()
    doc["design"][field] = value
    with pytest.raises(SpecError, match=rf"field 'design\.{field}'.*{re.escape(message)}"):
        spec_from_dict(doc)


def test_design_settings_default_to_the_bcc_weights_and_the_full_model():
    doc = _doc()
    del doc["design"]
    st = design_settings(spec_from_dict(doc))
    assert (st.q_scale, st.r, st.zeta_min, st.default_model) == (1.0, 0.22, 0.03, "full")
    del doc["instrumentation"], doc["test"]
    with pytest.raises(SpecError, match="instrumentation"):
        design_settings(spec_from_dict(doc))


@pytest.mark.parametrize("args", [
    ["modes", "{f}"], ["design", "{f}"], ["crosscheck", "{f}"], ["experiment", "{f}", "--plant", "linear"],
    ["export-mjcf", "{f}"], ["diagnose", "--structure", "{f}", "--recording", "{f}"],
])
def test_every_command_names_a_missing_or_invalid_structure_file(tmp_path, args):
    missing = tmp_path / "missing.toml"
    res = runner.invoke(app, [a.format(f=missing) for a in args])
    assert res.exit_code == 2 and "missing.toml: file not found" in res.output, res.output
    bad = tmp_path / "bad.toml"
    bad.write_text("[structure]\nname = 3\n")
    res = runner.invoke(app, [a.format(f=bad) for a in args])
    assert res.exit_code == 2 and "bad.toml" in res.output and "structure.name" in res.output, res.output


def test_unknown_structure_name_lists_the_shipped_ones():
    res = runner.invoke(app, ["modes", "tower"])
    assert res.exit_code == 2 and "'bcc'" in res.output and ".toml" in res.output


def test_a_test_table_in_a_shipped_file_would_have_to_reproduce_tests():
    # TESTS is the shipped tests' source; a [test] table added to bcc.toml/grid.toml must not drift from it
    for name in ("bcc", "grid"):
        if "test" in tomllib.loads((STRUCTURES_DIR / f"{name}.toml").read_text()):
            assert load_spec(name).test == TESTS[name]
