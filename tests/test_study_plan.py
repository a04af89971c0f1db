"""``python -m studies plan``: validation, the runs to do and their estimated cost, before any run."""
import os
import subprocess
import sys

import numpy as np
import pytest

from studies import cost as C
from studies import plan as P
from studies import spec as S


def test_the_cost_model_predicts_each_studys_runs_from_the_other_studies_records_within_a_factor_of_three():
    """Leave one study out: its runs' CPU time against the per-body-step cost of all other studies."""
    recs = C.committed_records()
    studies = sorted({os.path.basename(os.path.dirname(os.path.dirname(p))) for p in recs})
    assert len(studies) >= 5
    for study in studies:
        mine = {p: r for p, r in recs.items() if f"/{study}/runs/" in p}
        others = {p: r for p, r in recs.items() if p not in mine}
        per = C.seconds_per_body_step(others)
        ratios = []
        for r in mine.values():
            bodies, steps = C.bodies_and_steps_run(r)       # a cooling run may stop before t_end
            ratios.append(per * bodies * steps / float(r.get("cpu_s") or r["wall_s"]))
        assert 1 / 3 < np.median(ratios) < 3, (study, np.median(ratios))


def test_plan_lists_the_runs_to_do_with_their_estimate_and_runs_nothing(tmp_path, capsys):
    with open(os.path.join(S.SPEC_DIR, "test.toml"), "rb") as f:
        import tomllib
        raw = tomllib.load(f)
    raw["study"]["results"] = str(tmp_path / "results")
    sp = S.validate(raw)
    lines = []
    total = P.plan(sp, log=lines.append)
    todo = [l for l in lines if l.startswith("  ")]
    assert len(todo) == len(S.runs(sp)) > 0
    assert all(l.endswith(" (model)") and (" h " in l or " min " in l) for l in todo)
    assert total > 0 and f"{len(todo)} to do: about" in lines[-1]
    assert not (tmp_path / "results").exists()          # nothing written


def test_plan_of_a_finished_study_has_nothing_to_do():
    lines = []
    assert P.plan(S.load(os.path.join(S.SPEC_DIR, "shapes.toml")), log=lines.append) == 0
    assert lines[-1].endswith("0 to do: 0.0 min of CPU")


def test_plan_of_a_bad_spec_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(open(os.path.join(S.SPEC_DIR, "test.toml")).read().replace("volume_fraction = 0.02",
                                                                             "volume_fraction = 0.7"))
    p = subprocess.run([sys.executable, "-m", "studies", "plan", str(bad)], capture_output=True, text=True,
                       cwd=S.ROOT)
    assert p.returncode == 2 and p.stdout == ""
    assert len(p.stderr.strip().splitlines()) == 1 and "cannot be placed" in p.stderr


def test_plan_does_not_count_a_flagged_run_as_to_do():
    """A flagged run is finished (its energy check failed; it is never rerun): sphere_gas has one."""
    lines = []
    P.plan(S.load(os.path.join(S.SPEC_DIR, "sphere_gas.toml")), log=lines.append)
    assert " 0 to do" in lines[-1], lines[-1]
