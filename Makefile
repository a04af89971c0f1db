# clumpprops: the README's two commands are `make run` and `make test`.
PY := .venv/bin/python
.PHONY: setup run test test-random fuzz bench example paper
setup:
	@bash scripts/setup.sh
# main job: the worked example, then the paper's Fig. 2 at the quick scale (~15 min, 2 cores)
run: setup
	$(PY) examples/paper_dimer.py
	OMP_NUM_THREADS=1 $(PY) -m studies.granular_gas run --scale quick
# the paper-scale study (the committed results/granular_gas)
paper: setup
	OMP_NUM_THREADS=1 $(PY) -m studies.granular_gas run --scale paper
test: setup
	OMP_NUM_THREADS=1 $(PY) -m pytest -q tests
# the property-based tests of the geometry with 10^4 fresh random examples each (hypothesis
# profile "random", tests/_profiles.py; CI uses the derandomized "ci" profile); hours, not minutes
test-random: setup
	HYPOTHESIS_PROFILE=random OMP_NUM_THREADS=1 $(PY) -m pytest -q tests/test_exact.py tests/test_invariance.py tests/test_validation.py tests/test_exact_degenerate.py
# fuzz the exact method: 10^4 random clumps, near-degenerate ones included (tests/fuzz_exact.py)
fuzz: setup
	OMP_NUM_THREADS=1 $(PY) tests/fuzz_exact.py --clumps 10000 --seed 0 --reference 100
example: setup
	$(PY) examples/paper_dimer.py
bench: setup
	OMP_NUM_THREADS=1 $(PY) benchmarks/bench_massprops.py
	OMP_NUM_THREADS=1 $(PY) benchmarks/bench_yade_build.py
	OMP_NUM_THREADS=1 $(PY) benchmarks/bench_gas.py
