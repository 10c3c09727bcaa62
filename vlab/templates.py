"""Commented structure files to start from (``vlab init KIND PATH``).

``beam`` and ``frame`` are the files of ``assets/templates`` (a clamped-free
beam with two coils; a U-shaped portal frame clamped at both feet), each
with a ``[test]`` and a ``[design]`` table. ``bcc`` and ``grid`` copy a
shipped structure file and append its test (:data:`vlab.experiment.config.TESTS`,
Sec. 5.4.2) and design settings (:data:`vlab.design.THESIS_SETTINGS`,
Secs. 6.1, 6.2) as tables, so that the copy keeps them when it is renamed; its weights stay in the
thesis units (``units = "thesis"``), the templates' are in SI (``units = "SI"``, :mod:`vlab.design.weights`).
Every template loads as written (:func:`vlab.spec.load_spec`). ``test`` writes
the setup of a test instead (:func:`write_test_setup`, a ``test.toml`` for
``vlab diagnose --test``).
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import OptionError
from .spec import ASSETS_DIR, STRUCTURES_DIR

#: Folder of the ``beam`` and ``frame`` templates.
TEMPLATES_DIR = ASSETS_DIR / "templates"

#: Kinds ``vlab init`` writes: new structures, and copies of the shipped ones.
TEMPLATE_KINDS = ("beam", "frame", "bcc", "grid")


def template_text(kind: str) -> str:
    """The text of a structure-file template.

    Parameters
    ----------
    kind : str
        One of :data:`TEMPLATE_KINDS`.

    Returns
    -------
    str
        TOML text in the format of ``assets/structures/*.toml``, commented.

    Raises
    ------
    OptionError
        Unknown kind (the message lists the kinds).
    """
    if kind in ("beam", "frame"):
        return (TEMPLATES_DIR / f"{kind}.toml").read_text(encoding="utf-8")
    if kind in ("bcc", "grid"):
        return _shipped_copy(kind)
    raise OptionError(f"unknown structure kind {kind!r}; use one of {', '.join(TEMPLATE_KINDS)}")


def _shipped_copy(name: str) -> str:
    """A shipped structure file with its test and design settings written out as tables."""
    from .design import THESIS_SETTINGS
    from .experiment.config import TESTS

    t = TESTS[name]
    d = THESIS_SETTINGS[name]
    head = (f"# A copy of the shipped structure {name!r} (written by `vlab init {name}`).\n"
            "# Its test (Sec. 5.4.2) and design settings (Secs. 6.1, 6.2) are written out below as [test] and\n"
            "# [design] tables, so that they stay when you rename the structure ([structure] name) and edit it.\n\n")
    test = (f"\n[test]\nsource = \"Sec. 5.4.2 (vlab.experiment.config.TESTS['{name}'])\"\n"
            f"band_hz = [{t.band_hz[0]!r}, {t.band_hz[1]!r}]\nresolution_hz = {t.resolution_hz!r}\n"
            f"rms_n = {t.rms_n!r}\nn_modes = {t.n_modes}\nresponse_point = {t.response_point}\n"
            f"measured_points = [{', '.join(str(p) for p in t.measured_points)}]\n"
            f"response_quantity = \"{t.response_quantity}\"\n")
    design = (f"\n[design]\nsource = \"Sec. 6.{1 if name == 'bcc' else 2} (vlab.design.THESIS_SETTINGS['{name}'])\"\n"
              f"zeta_min = {d.zeta_min!r}\nn_modes = {d.n_modes}\nn_f = {d.n_f}\n"
              "units = \"thesis\"                   # the weights below in the dissertation's units (in, lbf, cs)\n"
              f"q_scale = {d.q_scale!r}\n"
              f"r = {d.r!r}\nv1 = {d.v1!r}\nv2 = {d.v2!r}\nalpha = {d.alpha!r}\n"
              + (f"r_corrected = {d.r_corrected!r}\n" if d.r_corrected is not None else "")
              + ("# default_model: the thesis designs DRF on the full model and LQG on the exact reduction\n"
                 if name == "bcc" else f"default_model = \"{d.default_model}\"\n"))
    return head + (STRUCTURES_DIR / f"{name}.toml").read_text(encoding="utf-8").rstrip("\n") + "\n" + test + design


def write_template(kind: str, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write the template of ``kind`` to ``path`` (atomically), checked to load as written.

    Parameters
    ----------
    kind : str
        One of :data:`TEMPLATE_KINDS`.
    path : str or Path
        A ``.toml`` file; its folder must exist.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        ``path``, the template written.

    Raises
    ------
    OptionError
        Unknown kind.
    OutputError
        ``path`` exists without ``overwrite``, is a folder, does not end in
        ``.toml``, or its folder is missing (:func:`vlab.io.atomic.check_output_file`).
    """
    from .io.atomic import atomic_file, check_output_file
    from .spec import load_spec

    text = template_text(kind)
    p = check_output_file(path, overwrite=overwrite, option="PATH", suffix=".toml")
    with atomic_file(p, overwrite=overwrite) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
        load_spec(tmp)  # same suffix (.toml): a template that does not load is never written
    return p


def write_test_setup(path: str | Path, structure: str, *, recording: str | Path | None = None,
                     overwrite: bool = False) -> Path:
    """Write a commented ``test.toml`` (:func:`vlab.io.setup_file.setup_text`), checked to read as written.

    Parameters
    ----------
    path : str or Path
        A ``.toml`` file; its folder must exist.
    structure : str
        A shipped structure's name or a structure file; its ``[instrumentation]`` excitation point is written.
    recording : str or Path, optional
        A recording of ``vlab experiment``: the metadata of its JSON sidecar (controller, reduction, seed,
        plant, resolution, chain) are written as the values.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    DataFileError
        ``recording`` has no sidecar, or an unreadable one.
    OutputError
        ``path`` exists without ``overwrite``, is a folder, does not end in ``.toml``, or its folder is missing.
    SpecError
        An unknown structure.
    """
    from .errors import DataFileError
    from .io.atomic import atomic_file, check_output_file
    from .io.setup_file import read_setup, setup_text
    from .io.uff_files import read_sidecar, sidecar_path
    from .spec import load_spec

    spec = load_spec(structure)
    meta = {}
    if recording is not None:
        meta = read_sidecar(Path(recording))
        if not meta:
            raise DataFileError(f"{recording}: no metadata sidecar {sidecar_path(recording)} to take the test from")
    instr = spec.instrumentation
    p = check_output_file(path, overwrite=overwrite, option="PATH", suffix=".toml")
    if str(structure).endswith(".toml"):  # read relative to the test file's folder
        structure = os.path.relpath(Path(structure).resolve(), p.resolve().parent)
    text = setup_text(structure, meta, excitation_point=None if instr is None else instr.excitation)
    with atomic_file(p, overwrite=overwrite) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
        read_setup(tmp)  # a setup that does not read back is never written
    return p
