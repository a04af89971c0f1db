# clumpprops: the README's two commands are `make run` and `make test`.
# VENV: the venv scripts/setup.sh makes and the targets use (default .venv; inside the
# Debian 13 root the repository is bind-mounted, so it uses $(VENV_D13) instead).
VENV ?= .venv
VENV_D13 ?= .venv-debian13
PY := $(VENV)/bin/python
D13 := bash scripts/debian13.sh
PYTEST_ARGS ?= -q
.PHONY: setup run test test-native test-debian13 setup-debian13 test-wheel docs test-fast test-random fuzz test-core asan bench example paper \
	science science-timestep science-maps science-estimator science-engines science-pairing
setup:
	@VENV=$(VENV) bash scripts/setup.sh
# main job: the worked example, then the paper's Fig. 2 at the quick scale (10 runs of 250 s on 2 cores: 9 min measured in a fresh clone on idle cores, 19-33 min beside make test or study sweeps)
run: setup
	$(PY) examples/paper_dimer.py
	OMP_NUM_THREADS=1 $(PY) -m studies run quick --allow-dirty
# the paper-scale study (the committed results/granular_gas)
paper: setup
	OMP_NUM_THREADS=1 $(PY) -m studies run paper
# the test suite on both YADE versions: natively (Debian 12, YADE 2023.02a), then inside the
# Debian 13 root (YADE 2025.2; built on first use, ~8 min, reused afterwards); both run even
# if the first fails, and the target fails if either does.  Both set-ups come first: native
# tests run YADE 2025.2 in the root too (the study engine), which needs the root's own build
# of the compiled core (Python 3.13)
test: setup setup-debian13
	@status=0; \
	$(MAKE) --no-print-directory test-native || status=1; \
	$(MAKE) --no-print-directory test-debian13 || status=1; \
	$(MAKE) --no-print-directory test-wheel || status=1; \
	$(MAKE) --no-print-directory docs || status=1; \
	exit $$status
# the library as pip users get it: sdist -> wheel -> a fresh venv without Debian's packages (PyPI),
# the library tests run from outside the tree, on Python 3.11 and 3.13 (scripts/test_wheel.sh)
test-wheel:
	bash scripts/test_wheel.sh
# the documentation site (Sphinx + MyST + numpydoc, Debian's packages): docs/ -> build/docs/index.html,
# every warning an error; the code examples of the pages run in tests/test_docs_examples.py
docs: setup
	rm -rf build/docs build/docs-doctrees
	OMP_NUM_THREADS=1 $(PY) -m sphinx -W --keep-going -q -b html -d build/docs-doctrees docs build/docs
# the library's own tests only (pytest -m library: no YADE, engines or studies), in under a minute
test-fast: setup
	OMP_NUM_THREADS=1 $(PY) -m pytest $(PYTEST_ARGS) -m library tests
test-native: setup
	OMP_NUM_THREADS=1 $(PY) -m pytest $(PYTEST_ARGS) tests
setup-debian13:
	$(D13) build
	$(D13) run env VENV=$(VENV_D13) bash scripts/setup.sh
test-debian13: setup-debian13
	$(D13) run env OMP_NUM_THREADS=1 $(VENV_D13)/bin/python -m pytest $(PYTEST_ARGS) -p no:cacheprovider tests
# the property-based tests of the geometry with 10^4 fresh random examples each (hypothesis
# profile "random", tests/_profiles.py; CI uses the derandomized "ci" profile); hours, not minutes
test-random: setup
	HYPOTHESIS_PROFILE=random OMP_NUM_THREADS=1 $(PY) -m pytest -q tests/test_exact.py tests/test_invariance.py tests/test_validation.py tests/test_exact_degenerate.py
# fuzz the exact method: 10^4 random clumps, near-degenerate ones included (tests/fuzz_exact.py)
fuzz: setup
	OMP_NUM_THREADS=1 $(PY) tests/fuzz_exact.py --clumps 10000 --seed 0 --reference 100
# the compiled core against the numpy oracle on 10^4 random / near-degenerate clumps, and the
# slicing reference on three clumps with 20-30 caps per sphere (tests/test_core.py; ~10 min)
test-core: setup
	CLUMPPROPS_CORE_CASES=10000 CLUMPPROPS_CORE_LONG=1 OMP_NUM_THREADS=1 $(PY) -m pytest -q tests/test_core.py
# memory safety: the core built with AddressSanitizer + UBSan (build/asan), the exact tests run on it
ASAN_TESTS := tests/test_core.py tests/test_exact.py tests/test_exact_degenerate.py tests/test_fuzz_exact.py tests/test_exact_reference.py tests/test_pairwise_physics.py tests/test_value_object.py tests/test_validation.py
asan: setup
	rm -rf build/asan build/asan-tmp
	CLUMPPROPS_SANITIZE=1 $(PY) setup.py -q build_ext --build-lib build/asan --build-temp build/asan-tmp >/dev/null
	CLUMPPROPS_CORE_DIR=$(CURDIR)/build/asan/clumpprops/core LD_PRELOAD="$$(g++ -print-file-name=libasan.so) $$(g++ -print-file-name=libubsan.so)" \
	  ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 OMP_NUM_THREADS=1 \
	  $(PY) -c 'import clumpprops.core._core as c, sys; print("[asan] core:", c.__file__); sys.exit("/build/asan/" not in c.__file__)'
	CLUMPPROPS_CORE_DIR=$(CURDIR)/build/asan/clumpprops/core LD_PRELOAD="$$(g++ -print-file-name=libasan.so) $$(g++ -print-file-name=libubsan.so)" \
	  ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 OMP_NUM_THREADS=1 \
	  $(PY) -m pytest -q -p no:cacheprovider $(ASAN_TESTS)
example: setup
	$(PY) examples/paper_dimer.py
# the speed and memory benchmarks (docs/benchmarks.md): each writes its figures to benchmarks/results/
bench: setup
	OMP_NUM_THREADS=1 $(PY) -m benchmarks.bench_core
	OMP_NUM_THREADS=1 $(PY) -m benchmarks.bench_massprops
	OMP_NUM_THREADS=1 $(PY) -m benchmarks.bench_yade_build
	OMP_NUM_THREADS=1 $(PY) -m benchmarks.bench_gas
	OMP_NUM_THREADS=1 $(PY) -m benchmarks.bench_io
# the studies beside the gas sweeps whose records are committed under results/ (docs/benchmarks.md,
# "Studies"; CPU-hours: the time-step study ~17 CPU-min per shape and stiffness, the collision maps
# 1-3 CPU-h each, the estimator's validation ~10 CPU-h).  The time-step study runs with the
# arguments its committed files record in "argv" (--workdir and --out aside; tests/test_timestep.py
# checks); the aspherical shapes run YADE 2025.2 in the Debian 13 root (scripts/debian13.sh)
science: science-timestep science-maps science-estimator science-engines science-pairing
science-timestep: setup
	OMP_NUM_THREADS=1 $(PY) -m studies timestep --factors-of trimer=0.0625,0.25,0.5,1.0,1.5,2.0 --bias 400,8 --bias-factors 0.5,1.0,1.5
	OMP_NUM_THREADS=1 $(PY) -m studies timestep --shapes tetra --factors-of tetra=0.0625,0.25,0.5,1.0,1.5,2.0 --gas-factors 0.5,1.0,1.5 --out results/timestep/timestep_tetra.json
	OMP_NUM_THREADS=1 $(PY) -m studies timestep --shapes dimer --youngs-modulus 1e8 --factors 0.125,0.25,0.5,1.0,1.25,1.58,2.0 --gas-factors 1.0,1.25,1.58 --out results/timestep/timestep_E1e8.json
	OMP_NUM_THREADS=1 $(PY) -m studies timestep --shapes dimer --youngs-modulus 1e9 --factors 0.125,0.25,0.5,1.0,1.25,1.58,2.0 --gas-factors 1.0,1.58,2.0 --out results/timestep/timestep_E1e9.json
# the collision maps with the arguments their files record (results/collision_map/*.json, "argv")
CM := OMP_NUM_THREADS=1 $(PY) -m studies case-map
CM_OUT := results/collision_map
science-maps: setup
	$(CM) --pairs 10000 --out $(CM_OUT)/case_map.json
	$(CM) --pairs 4000 --youngs-modulus 1e8 --out $(CM_OUT)/case_map_E1e8.json
	$(CM) --pairs 4000 --youngs-modulus 1e9 --out $(CM_OUT)/case_map_E1e9.json
	for d in 0.25 0.375 0.625 0.75; do $(CM) --pairs 4000 --overlap $$d --out $(CM_OUT)/case_map_d$$d.json || exit 1; done
	for s in tetrahedron trimer_triangle; do \
	  $(CM) --pairs 4000 --shape $$s --out $(CM_OUT)/case_map_$$s.json && \
	  $(CM) --pairs 4000 --shape $$s --youngs-modulus 1e9 --out $(CM_OUT)/case_map_$${s}_E1e9.json || exit 1; done
# the estimator: on Ornstein-Uhlenbeck walkers, the hard-sphere gas's VACF and the Boltzmann VACF
science-estimator: setup
	OMP_NUM_THREADS=1 $(PY) -m studies estimator-validation > results/estimator/estimator.txt && cat results/estimator/estimator.txt
	OMP_NUM_THREADS=1 $(PY) -m studies vacf-shape
	OMP_NUM_THREADS=1 $(PY) -m studies gk-boltzmann --runs 300 --ref-chains 8000
# what LIGGGHTS and LAMMPS compute for a clump on their own (a script among the engine tests' helpers)
science-engines: setup
	OMP_NUM_THREADS=1 $(PY) tests/engine_errors.py
science-pairing: setup
	OMP_NUM_THREADS=1 $(PY) -m studies pair-correlation > results/pairing/pair_correlation.txt && cat results/pairing/pair_correlation.txt
