"""Controller designs of the nominal BCC shared by the tests, each made once per test process.

The MFDRF design runs the optimiser's multi-start (about 2 s); a dozen tests in several files read the
same nominal design (``vlab.design("bcc", c)`` = ``design_controller(nominal_fe_model("bcc"), c)`` with
the default seed and period). :class:`vlab.design.ControllerDesign` is a frozen dataclass and no test
writes into its arrays, so the cached object is handed out as is. Tests of the design itself (seeds,
periods, reductions) call :func:`vlab.design.design_controller` directly.
"""

from __future__ import annotations

from functools import lru_cache

from vlab.design import design_controller
from vlab.models import nominal_fe_model


@lru_cache(maxsize=None)
def bcc_design(controller: str):
    """``design_controller(nominal_fe_model("bcc"), controller)`` with its defaults, cached."""
    return design_controller(nominal_fe_model("bcc"), controller)
