"""From run records to per-run D, and the sequential design of a study.

Pure functions of run records (the JSON files of :mod:`studies.runner`); no Dask, no YADE,
no driver.  The driver (:mod:`studies.engine`) asks :func:`plan` which seeds a sequential
group needs next; the analysis (:mod:`studies.analysis`) uses :func:`run_d` for every run.

* **The analysis window.**  ``analysis.t_eq`` in seconds, or ``"auto"``: the equilibration cut
  detected from the record's rotational share of kinetic energy
  (:func:`studies.equilibration.detect_equilibration`, equipartition 2/5 for linear clumps, 1/2
  for others), rounded up to the next stored window start (``analysis.cuts``).  Runs started
  in equilibrium (``gas.start = "equipartition"``) and sphere gases have no transient: "auto"
  uses their whole run (the first stored window).
* **D of one run**: Green-Kubo on the record's velocity autocorrelation
  (:func:`studies.diffusion.diffusion_green_kubo`, e-folding truncation plus a fitted
  exponential tail; validated on Ornstein-Uhlenbeck walkers in benchmarks/bench_estimator.py),
  with a jackknife standard error over the record's particle groups.  Published intervals use
  the seeds as the independent units: a Student-t interval over per-seed values or per-seed
  paired differences.
* **Sequential design.**  A group with ``target = {case, halfwidth, batch, observable}`` and
  ``max_seeds`` starts with its ``seeds``; whenever all its runs are finished, the 95 % half-width
  of the paired relative difference X_case / X_exact - 1 over seeds (X: D of an elastic gas; of a
  cooling gas the target's ``observable``, ``cooling_rate``, ``temperature_ratio`` or
  ``diffusion``, :func:`run_observable`) is compared with ``halfwidth``
  (:func:`studies.sequential.sequential_status`: a rule on the spread, never on the mean), and
  ``batch`` more seeds are added until the target is met, ``max_seeds`` is reached, or the
  spec's ``study.budget_cpu_hours`` is spent.  The added seeds follow from the records alone, so
  a stopped study resumes the same design on any machine.
"""
from __future__ import annotations

import dataclasses
import functools
import json

import numpy as np

from . import diffusion, equilibration, hcs, intervals, sequential
from . import reduce as red
from . import spec as S
from .cost import (_key_without, _median_like, _run_cost, cost_scale, expected_wall_s,  # noqa: F401
                   expected_wall_s_in, read_records)

ESTIMATOR = "green_kubo"


def equipartition_share(rec):
    """Equipartition value of E_rot / (E_trans + E_rot): 2/5 linear clumps, 1/2 others, 0 spheres."""
    dof = rec["rot_dof"]
    return dof / (3.0 + dof)


def analysis_cut(rec, t_eq):
    """Start (s) of the record's analysis window for ``t_eq`` (seconds or "auto"); returns
    (t_cut, detected) where ``detected`` is the detected cut (s) or None."""
    cuts = sorted(w["t_cut"] for w in rec["windows"])
    if t_eq != "auto":
        return float(t_eq), None
    if rec["rot_dof"] == 0:                 # spheres: no rotation, equilibrium from the start
        return cuts[0], 0.0
    if rec.get("params", {}).get("gas", {}).get("start") == "equipartition":
        # Started in equilibrium (Maxwellian velocities, spins at equipartition, uniform positions
        # at phi << 1): there is no transient to cut, so the whole run is used.  The detector is
        # not consulted: its false-alarm rate (<= alpha = 5 % per run, Bonferroni over blocks)
        # would drop data from some runs at random, a data-dependent choice for no gain.
        return cuts[0], None
    e = rec["energy"]
    tr, ro = np.asarray(e["e_trans"]), np.asarray(e["e_rot"])
    det = equilibration.detect_equilibration(np.asarray(e["t"]), ro / (tr + ro), equipartition_share(rec))
    t_det = det["t_cut"]
    if not np.isfinite(t_det):
        raise ValueError(f"run {rec['name']}: no equilibration cut (rotational share never settles at "
                         f"{equipartition_share(rec):.2f})")
    later = [c for c in cuts if c >= t_det - 1e-9]
    if not later:
        raise ValueError(f"run {rec['name']}: detected cut {t_det:.0f} s is after every stored window {cuts}")
    return later[0], float(t_det)


def window_of(rec, t_cut):
    for w in rec["windows"]:
        if abs(w["t_cut"] - t_cut) < 1e-9:
            return w
    raise KeyError(f"run {rec['name']} has no analysis window from t = {t_cut} s "
                   f"(stored: {[w['t_cut'] for w in rec['windows']]}): add it to analysis.cuts and rerun")


def run_d(rec, t_eq, stderr=True):
    """Green-Kubo D (m^2/s) of one run record, its jackknife SE over particle groups (m^2/s), and the
    cut (s).  ``stderr=False`` leaves the SE out (``D_stderr`` None): the jackknife refits D once per
    particle group, eight times the cost of D, and the paired comparisons over seeds never read it
    (so a record whose jackknife would fail still gives its D there; :mod:`studies.analysis`, which
    reports the SE, still stops on it)."""
    t_cut, detected = analysis_cut(rec, t_eq)
    w = window_of(rec, t_cut)
    lag = np.arange(len(w["vacf"])) * w["frame_interval"]      # the stored lags are rounded to 7 digits
    try:
        d = diffusion.diffusion_green_kubo(lag, np.asarray(w["vacf"]))
        se = diffusion.green_kubo_stderr(lag, np.asarray(w["vacf_groups"])) if stderr else None
    except ValueError as e:
        raise ValueError(f"run {rec['name']}: no Green-Kubo D from the window at {t_cut} s: {e}") from None
    return {"D": float(d), "D_stderr": None if se is None else float(se), "t_cut": t_cut, "t_cut_detected": detected}


def possible_extra_seeds(spec):
    """{group index: every seed :func:`plan` could ever add}: the next integers after the largest
    listed seed, up to ``max_seeds`` seeds in the group (sequential groups only)."""
    out = {}
    for gi, g in enumerate(spec["groups"]):
        if g.get("target"):
            nxt = max(g["seeds"]) + 1
            out[gi] = list(range(nxt, nxt + max(0, g["max_seeds"] - len(g["seeds"]))))
    return out


def load_records(spec, rdir):
    """Every finished record of a spec's runs that serves its analysis (:func:`studies.reduce.serves`),
    by key (runs without one are left out: the driver runs them again), the seeds the sequential
    design added included."""
    out = {}
    needs = S.analysis_windows(spec)
    for run in S.runs(spec, extra_seeds=possible_extra_seeds(spec)):
        path = red.record_path(rdir, run)
        if red.is_complete(path, run["key"], needs):
            with open(path) as f:
                out[run["key"]] = json.load(f)
    return out


def cpu_hours(recs):
    """CPU-hours of the runs behind the records: each run's YADE process CPU time (``cpu_s``;
    records made before it was recorded count their wall time, an upper bound)."""
    return float(sum(r.get("cpu_s", r["wall_s"]) for r in recs.values())) / 3600.0


def _sequential_runs(spec, gi, seeds):
    """The runs (key, case, seed) of group gi for the given seeds, shared runs included."""
    g = spec["groups"][gi]
    out = []
    for seed in seeds:
        for case in g["cases"]:
            out.append({"key": S.run_key(S.resolve_run(spec, g, case, seed)), "case": case, "seed": seed})
    return out


def run_observable(rec, observable, t_eq):
    """The value of a sequential target's observable in one run: D (Green-Kubo, :func:`run_d`) of an
    elastic run; of a cooling run (a record with an ``hcs`` part), ``observable`` from
    :func:`studies.hcs.effect_observables` (D0 from the MSD from the first frame, which every
    cooling record has).  NaN where the run's window cannot be analysed."""
    if "hcs" not in rec:
        return run_d(rec, t_eq, stderr=False)["D"]
    try:
        x = hcs.effect_observables(rec["hcs"])
    except ValueError:
        return float("nan")
    return x[observable]


def paired_relative(recs_by_key, runs, case, t_eq, observable="diffusion"):
    """Per-seed X_case / X_exact - 1 of a target's observable (:func:`run_observable`) for the seeds
    where both runs are finished, passed their checks and give a finite value: list of (seed, value)."""
    by = {}
    for r in runs:
        rec = recs_by_key.get(r["key"])
        if rec is not None and rec["checks"]["ok"]:
            by.setdefault(r["seed"], {})[r["case"]] = run_observable(rec, observable, t_eq)
    out = [(s, v[case] / v["exact"] - 1.0) for s, v in sorted(by.items()) if case in v and "exact" in v]
    return [(s, x) for s, x in out if np.isfinite(x)]


def plan(spec, rdir, recs=None):
    """Extra seeds per sequential group, and a status line per group.

    Returns (extra_seeds {group index: [seeds]}, status {group index: dict}).  A group's extra
    seeds are the next integers after its largest listed seed, added ``batch`` at a time while
    its target is not met, it has fewer than ``max_seeds`` seeds, and the budget allows.
    """
    recs = load_records(spec, rdir) if recs is None else recs
    spent = cpu_hours(recs)
    extra, status = {}, {}
    for gi, g in enumerate(spec["groups"]):
        if not g.get("target"):
            continue
        seeds, pairs, st = _grow_group(spec, gi, recs, spent)
        nxt = max(seeds) + 1
        extra[gi] = [s for s in seeds if s not in g["seeds"]]
        st["cpu_hours_per_pair"] = pair_cost(spec, gi, nxt, recs)
        n_more = None if st.get("n_needed") is None else max(0, st["n_needed"] - st["n"])
        if n_more is None or st["met"]:
            st["cpu_hours_to_target"] = None
        else:   # the group's seeds without a pair yet, then the next integers, until n_more of them
            st["cpu_hours_to_target"] = _cost_to_target(spec, gi, seeds, {sd for sd, _ in pairs}, nxt, n_more, recs)
        status[gi] = st
    return extra, status


def _grow_group(spec, gi, recs, spent):
    """A sequential group's seeds, ``batch`` more at a time while all its runs are finished and it
    may grow; returns (seeds, its paired values [(seed, value)], its status dict with ``state``)."""
    g = spec["groups"][gi]
    target = g["target"]
    budget = spec["study"].get("budget_cpu_hours")
    seeds = list(g["seeds"])
    while True:
        runs = _sequential_runs(spec, gi, seeds)
        finished = all(r["key"] in recs for r in runs)
        pairs = paired_relative(recs, runs, target["case"], spec["analysis"]["t_eq"], target["observable"])
        st = sequential.sequential_status([v for _, v in pairs], target["halfwidth"], max_n=g["max_seeds"])
        st.update(case=target["case"], observable=target["observable"], target=target["halfwidth"], seeds=len(seeds),
                  finished=finished,
                  cpu_hours=spent, budget_cpu_hours=budget)
        st["state"] = _stop_state(st, runs, recs, len(seeds), g["max_seeds"], budget, spent)
        if st["state"] is not None:
            return seeds, pairs, st
        nxt = max(seeds) + 1
        seeds += list(range(nxt, nxt + min(target["batch"], g["max_seeds"] - len(seeds))))


def _stop_state(st, runs, recs, n_seeds, max_seeds, budget, spent):
    """Why a sequential group adds no seed now (its ``state``), or None when it adds a batch."""
    if not st["finished"]:
        return "running" if any(r["key"] in recs for r in runs) else "not started"
    if st["met"]:
        return "target met"
    if n_seeds >= max_seeds:
        return "max_seeds reached"
    if budget is not None and spent >= budget:
        return "budget spent"
    return None


def pair_cost(spec, gi, seed, recs):
    """CPU-hours of one more seed of group gi: per case, the median CPU time of the finished runs of
    that case (any seed) made at the time step ``seed`` would use; None until each case has one."""
    g = spec["groups"][gi]
    costs = [_run_cost(S.resolve_run(spec, g, case, seed), recs) for case in g["cases"]]
    return None if any(c is None for c in costs) else float(sum(costs))


def _cost_to_target(spec, gi, seeds, paired, nxt, n_more, recs):
    """CPU-hours for n_more more pairs of group gi: its listed seeds without a pair first, then the
    next integers from ``nxt``.  Seeds past every recorded seed and past the legacy time-step bound
    all cost the same, so they are priced once (n_more can be 1e5 for a far target)."""
    todo = [sd for sd in seeds if sd not in paired][:n_more]
    rest = n_more - len(todo)
    legacy = (spec["run"].get("legacy_dt") or {}).get("below_seed", 0)
    last = max([int(r["params"]["seed"]) for r in recs.values()] + [legacy, nxt - 1])
    explicit = list(range(nxt, min(nxt + rest, last + 1)))
    total = cost_of_seeds(spec, gi, todo + explicit, recs)
    n_far = rest - len(explicit)
    if total is None or n_far <= 0:
        return total
    per = cost_of_seeds(spec, gi, [max(last + 1, nxt)], recs)
    return None if per is None else total + n_far * per


def cost_of_seeds(spec, gi, seeds, recs):
    """CPU-hours still to spend for group gi's pairs at ``seeds``: the median cost of each run not
    finished yet.  A run already made (by this group or by another group that shares it, such as
    the ``exact`` run of a seed) costs nothing, so a group comparing one more case with existing
    exact runs costs one run a pair, not two.  None while some needed run's cost is unknown."""
    g = spec["groups"][gi]
    total = 0.0
    for seed in seeds:
        for case in g["cases"]:
            p = S.resolve_run(spec, g, case, seed)
            if S.run_key(p) in recs:
                continue
            c = _run_cost(p, recs)
            if c is None:
                return None
            total += c
    return total


def _prior_key(params):
    """What a prior projection must share with its reference: everything in a run's parameters but
    the seed, the Young's modulus, the run length, the time-step factor and the versions."""
    return _key_without(params, top=("seed", "model_version", "clumpprops_version"),
                        material=("youngs_modulus",), run=("t_end", "dt_factor"))


def prior_projection(spec, gi, refs):
    """Pairs and CPU-hours a sequential group's target would need, projected before it has two
    pairs of its own from a reference group that has: the same shape, gas, case, protocol and
    start at another Young's modulus or run length.

    ``refs``: candidate references, [(spec, group index, status of :func:`plan`, records)].  The
    reference is chosen by :func:`_reference_rank`: one with a full pilot (``MIN_PAIRS``) first,
    then the nearest stiffness, the nearest run length, the most pairs.  Scalings (assumptions,
    stated with the result): the per-pair standard deviation of D_case/D_exact - 1 as 1/sqrt(T) of
    the analysed length T (the reference's mean analysis cut taken off both run lengths); the CPU
    cost of a pair as the reference's times :func:`cost_scale` (run length, and steps per simulated
    second when more: sqrt(E) / dt_factor): an upper bound, since the recording's cost per
    simulated second does not grow with E (the committed sphere-gas runs cost 1.9x more per
    simulated second at 1e8 Pa than at 1e7 Pa, not 3.2x).  Returns None without a reference, else a dict: ``ref`` (study name), ``ref_pairs``,
    ``ref_youngs_modulus`` (Pa), ``ref_t_end`` (s), ``sd`` (scaled), ``n_needed``,
    ``halfwidth_at_max`` (at ``max_seeds``), ``max_seeds``, ``cpu_hours_per_pair``,
    ``cpu_hours_to_target`` (for ``n_needed`` pairs; None where the reference's run cost is not
    known).
    """
    g = spec["groups"][gi]
    target = g["target"]
    p = S.resolve_run(spec, g, target["case"], g["seeds"][0])
    ref = _choose_reference(spec, gi, p, refs)
    if ref is None:
        return None
    cut = ref.mean_cut()
    t, t_ref = float(p["run"]["t_end"]), float(ref.params["run"]["t_end"])
    if t <= cut:
        return None
    sd = ref.status["sd"] * np.sqrt((t_ref - cut) / (t - cut))
    need = sequential.pairs_needed(sd, target["halfwidth"], sequential.MIN_PAIRS)
    max_n = g.get("max_seeds")
    hw_max = None if max_n is None or max_n < 2 else float(intervals.t_quantile(0.95, max_n - 1) * sd / np.sqrt(max_n))
    per = ref.pair_cost_for(p)
    return {"ref": ref.spec["study"]["name"], "ref_pairs": int(ref.status["n"]),
            "ref_youngs_modulus": float(ref.params["material"]["youngs_modulus"]),
            "ref_t_end": t_ref, "sd": float(sd), "n_needed": int(need), "halfwidth_at_max": hw_max,
            "max_seeds": max_n, "cpu_hours_per_pair": per,
            "cpu_hours_to_target": None if per is None else per * need}


@dataclasses.dataclass
class Reference:
    """The reference group of a prior projection (:func:`prior_projection`): its spec, group index,
    status (:func:`plan`), records (by key) and the resolved parameters of its first run of the case."""

    spec: dict
    gi: int
    status: dict
    recs: dict
    params: dict

    @property
    def group(self):
        return self.spec["groups"][self.gi]

    @functools.cached_property
    def finished_runs(self):
        """Its runs (key, case, seed) with a record, at the seeds listed and added by the design."""
        seeds = list(self.group["seeds"]) + possible_extra_seeds(self.spec).get(self.gi, [])
        return [r for r in _sequential_runs(self.spec, self.gi, seeds) if r["key"] in self.recs]

    def mean_cut(self):
        """The mean analysis cut [s] of its finished runs (0 without any)."""
        t_eq = self.spec["analysis"]["t_eq"]
        cuts = [analysis_cut(self.recs[r["key"]], t_eq)[0] for r in self.finished_runs]
        return float(np.mean(cuts)) if cuts else 0.0

    def pair_cost_for(self, p):
        """CPU-hours of a pair at the target's parameters ``p``: a new pair of the reference (at the
        design's next seed and its time step) times :func:`cost_scale`; None where not known."""
        next_seed = max([int(r["seed"]) for r in self.finished_runs] + list(self.group["seeds"])) + 1
        ref_pair = pair_cost(self.spec, self.gi, next_seed, self.recs)
        if ref_pair is None:
            return None
        ref_f = S.resolve_run(self.spec, self.group, self.status["case"], next_seed)["run"]["dt_factor"]
        return ref_pair * cost_scale(p, dict(self.params, run=dict(self.params["run"], dt_factor=ref_f)))


def _choose_reference(spec, gi, p, refs):
    """The best :class:`Reference` among ``refs`` for group gi's target parameters ``p``
    (:func:`_reference_rank`; a full tie goes to the first study name), or None."""
    case = spec["groups"][gi]["target"]["case"]
    key = _prior_key(p)
    cands = []
    for rsp, rgi, rst, rrecs in refs:
        if rst.get("case") != case or rst["n"] < 2 or not (rst["sd"] == rst["sd"]):
            continue
        rg = rsp["groups"][rgi]
        rp = S.resolve_run(rsp, rg, case, rg["seeds"][0])
        if _prior_key(rp) != key or (rsp is spec and rgi == gi):
            continue
        cands.append((_reference_rank(p, rp, rst["n"]), rsp["study"]["name"], rgi, Reference(rsp, rgi, rst, rrecs, rp)))
    if not cands:
        return None
    cands.sort(key=lambda c: (c[1], c[2]))      # a full tie goes to the first study name, not the first found
    return max(cands, key=lambda c: c[0])[3]


def _reference_rank(p, rp, n):
    """Sort key (larger is better) of a prior projection's reference run parameters ``rp`` with
    ``n`` pairs for the target's parameters ``p``: a reference with at least ``sequential.MIN_PAIRS`` pairs
    (its spread is a pilot's, not two pairs'), then the smallest |ln E/E_ref| (the physics nearest
    the target's), then the smallest |ln T/T_ref| (the least scaling of the spread), then the most
    pairs, then a softer reference (E_ref < E) before a stiffer one at the same distance, then a
    longer run before a shorter one.  The most pairs alone would keep, on an equal count, the first
    reference found even at a farther stiffness."""
    e, e_ref = float(p["material"]["youngs_modulus"]), float(rp["material"]["youngs_modulus"])
    t, t_ref = float(p["run"]["t_end"]), float(rp["run"]["t_end"])
    return (n >= sequential.MIN_PAIRS, -round(abs(float(np.log(e / e_ref))), 12), -round(abs(float(np.log(t / t_ref))), 12),
            n, e_ref <= e, t_ref >= t)


def shape_label(g):
    """A group's shape as the status lines and the report name it: "dimer", or "dimer at E = 1e+08 Pa"
    for a group that sets its own Young's modulus (a stiffness series)."""
    return g["shape"] + ("" if g.get("youngs_modulus") is None else f" at E = {float(g['youngs_modulus']):g} Pa")


def describe(gi, g, st):
    hw = st["halfwidth"]
    hw_s = "n/a" if not (hw == hw) else f"{100 * hw:.2f} %"
    proj = "" if st.get("n_needed") is None else f", projected {st['n_needed']} pairs for the target"
    if hw == hw and hw <= st["target"] and st["n"] < st.get("min_n", 0):
        proj = f", within the target but short of the design's minimum of {st['min_n']} pairs"
    if st.get("cpu_hours_to_target") is not None:
        per = "" if st.get("cpu_hours_per_pair") is None else f"; {st['cpu_hours_per_pair']:.2f} CPU-h a new pair"
        proj += f" (about {st['cpu_hours_to_target']:.0f} CPU-h more, runs already made not counted{per})"
    obs = "" if st.get("observable", "diffusion") == "diffusion" else f", {st['observable']}"
    return (f"group {gi} ({shape_label(g)}: {st['case']} vs exact{obs}, {g.get('protocol', 'paired')}): {st['state']}; "
            f"{st['n']} pairs, 95 % half-width "
            f"{hw_s} (target {100 * st['target']:.2f} %){proj}; {st['cpu_hours']:.1f} CPU-h spent"
            + (f" of {st['budget_cpu_hours']:g}" if st["budget_cpu_hours"] is not None else ""))
