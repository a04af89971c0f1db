"""The hcs_clumps spec's runs that the cooling-gas analysis tests build synthetic records for."""
from studies import spec as S


def rough_dimer_runs(seeds):
    """The exact and uncorrected runs of hcs_clumps' frictional dimer at ``seeds``, in the spec's
    order (each run's ``params`` as ``studies.spec.runs`` gives them)."""
    spec = S.load(S.spec_path("hcs_clumps"))
    return [r for r in S.runs(spec) if r["params"]["shape"]["definition"]["kind"] == "dimer"
            and "friction" in r["params"]["material"] and r["params"]["case"] in ("exact", "uncorrected")
            and r["params"]["seed"] in seeds]
