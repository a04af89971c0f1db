"""The committed run records keep their keys: the current specs and code resolve every record's run
to the parameters, key and file name it was recorded under (:func:`studies.spec.resolve_run`,
:func:`studies.spec.run_key`).  A change of the key computation, of a resolved parameter or of a
spec that the committed studies were run from fails here."""
from __future__ import annotations

import glob
import json
import os

import pytest

from studies import design
from studies import spec as S

SPECS = sorted(p for p in glob.glob(os.path.join(S.SPEC_DIR, "*.toml")))


def _studies_with_records():
    out = []
    for path in SPECS:
        spec = S.load(path)
        if glob.glob(os.path.join(S.results_dir(spec), "runs", "*.json")):
            out.append(pytest.param(path, id=os.path.basename(path)[:-5]))
    return out


STUDIES = _studies_with_records()


def test_every_study_folder_with_records_has_a_spec():
    folders = {os.path.dirname(os.path.dirname(p)) for p in glob.glob(os.path.join(S.ROOT, "results", "*", "runs", "*.json"))}
    served = {os.path.realpath(S.results_dir(S.load(p.values[0]))) for p in STUDIES}
    assert folders and {os.path.realpath(f) for f in folders} <= served


@pytest.mark.parametrize("path", STUDIES)
def test_committed_records_keep_their_keys(path):
    spec = S.load(path)
    runs = {r["key"]: r for r in S.runs(spec, extra_seeds=design.possible_extra_seeds(spec))}
    files = sorted(glob.glob(os.path.join(S.results_dir(spec), "runs", "*.json")))
    assert files
    for file in files:
        with open(file) as f:
            rec = json.load(f)
        assert S.run_key(rec["params"]) == rec["key"], file
        run = runs.get(rec["key"])
        assert run is not None, f"{file}: the spec no longer resolves a run with key {rec['key']}"
        assert run["params"] == rec["params"], file
        assert run["name"] + ".json" == os.path.basename(file)
        assert (run["case"], run["protocol"], run["seed"]) == (rec["case"], rec["protocol"], rec["seed"])


@pytest.mark.parametrize("name", [
    "shapes/runs/dimer025-exact-paired-s1-9e86f0c2.json",
    "sphere_gas/runs/dimer-spheres-paired-s1-619542b6.json",
    "stiffness/runs/dimer-exact-paired-s1-83e4e398.json",
])
def test_a_committed_key_is_the_sha256_prefix_of_its_canonical_parameters(name):
    """The key is the first 16 hex digits of the SHA-256 of the parameters' canonical JSON (sorted
    keys, no spaces); the file name carries its first 8."""
    import hashlib

    with open(os.path.join(S.ROOT, "results", name)) as f:
        rec = json.load(f)
    canonical = json.dumps(rec["params"], sort_keys=True, separators=(",", ":"))
    assert rec["key"] == hashlib.sha256(canonical.encode()).hexdigest()[:16] == S.run_key(rec["params"])
    assert name.endswith(f"-{rec['key'][:8]}.json")
