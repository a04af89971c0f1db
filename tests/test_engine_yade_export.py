"""The YADE export (``clumpprops export FILE --to yade``) loaded into real YADE: ymport.textClumps
builds summed clumps (overlaps twice), clumpprops.yade.text_clumps the exact ones."""
from __future__ import annotations

import numpy as np

from _yadehelpers import O, PAPER_RHO, assert_state_matches, fresh_scene
import clumpprops
from clumpprops import yade as cy
from clumpprops.io import Clump, export

from _engines import ASYM_C, ASYM_R


def test_yade_export_in_yade(tmp_path):
    from yade import ymport

    clumps = [Clump(ASYM_C, ASYM_R, name="asym"), Clump(ASYM_C + [1.0, 0, 0], ASYM_R[::-1], name="asym2")]
    (path,) = export(clumps, "yade", tmp_path, density=PAPER_RHO, stem="two")
    exact = [clumpprops.mass_properties(c.centers, c.radii, PAPER_RHO) for c in clumps]
    summed = [clumpprops.mass_properties(c.centers, c.radii, PAPER_RHO, method="sum") for c in clumps]
    try:
        fresh_scene()
        ret = cy.text_clumps(str(path), material="mat")
        for (cid, _), mp in zip(ret, exact):
            assert_state_matches(O.bodies[cid].state, mp)
        fresh_scene()
        ret = ymport.textClumps(str(path), material="mat")
        clump_ids = sorted({b.clumpId for b in O.bodies if b.isClumpMember})
        assert len(clump_ids) == 2
        for cid, sm in zip(clump_ids, summed):
            assert abs(float(O.bodies[cid].state.mass) / sm.mass - 1) < 1e-12
    finally:
        O.reset()
