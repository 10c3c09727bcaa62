"""A member split into pieces by an edit of some segments' rigidity keeps the plant resolution its member was given.

A spec edit (a segment's rigidity scaled, a joint softened) cuts the member into pieces ``m[a-b]``
(:func:`vlab.spec.changes.piece_id`); a resolution set for the member by id -- ``SimOptions.member_segments``
or the structure file's ``[mujoco] segments`` -- must reach its pieces, or the edited plant is built coarser
than the unedited one and the edit's effect is mixed with a discretisation change (measured on the BCC's
converged plant, 4 links per segment: cutting the beam at segments 4-5 and 5-6 without changing anything
raised mode 6 by 0.34 %; the FE model, by construction, did not move).
"""

from __future__ import annotations

import numpy as np
import pytest

from vlab.diagnose.effects import specedit
from vlab.sim import SimOptions
from vlab.sim.crosscheck import crosscheck
from vlab.spec import load_spec
from vlab.spec.changes import cut_from, piece_ends, piece_id, unique_id


def test_a_piece_id_names_the_member_it_was_cut_from():
    assert piece_id("beam", 4, 5) == "beam[4-5]"
    assert cut_from("beam[4-5]") == "beam"
    assert cut_from(unique_id({"beam[4-5]"}, "beam[4-5]")) == "beam"  # beam[4-5]_2
    assert cut_from("bar_10_12[10-11]") == "bar_10_12"
    assert cut_from("beam") is None and cut_from("beam[4]") is None
    assert piece_ends("beam[4-5]_2") == ("beam", 4, 5) and piece_ends("beam") is None


@pytest.mark.parametrize("how", ["options", "spec"])
def test_cutting_a_member_without_changing_it_leaves_the_plant_as_it_was(how):
    spec = load_spec("bcc")
    cut = specedit.scale_segments(spec, {(4, 5): 1.0, (5, 6): 1.0})
    assert {m.id for m in cut.members} == {"beam[1-4]", "beam[4-5]", "beam[5-6]", "beam[6-9]"}
    if how == "spec":
        spec, cut = (s.replace(mujoco={**s.mujoco, "segments": {"beam": 3}}) for s in (spec, cut))
        opts = None
    else:
        opts = SimOptions(member_segments={"beam": 3})
    whole, pieces = (crosscheck(s, 6, options=opts) for s in (spec, cut))
    f_whole = np.array([p.sim_hz for p in whole.pairs])
    f_pieces = np.array([p.sim_hz for p in pieces.pairs])
    assert np.allclose(f_pieces, f_whole, rtol=1e-6), (f_whole, f_pieces)
    default = np.array([p.sim_hz for p in crosscheck(load_spec("bcc"), 6).pairs])
    assert not np.allclose(f_whole, default, rtol=1e-5)  # the setting did change the plant: the test can fail
