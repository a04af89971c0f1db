# clumpprops: the README's two commands are `make run` and `make test`.
PY := .venv/bin/python
.PHONY: setup run test test-random fuzz test-core asan bench example paper
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
bench: setup
	OMP_NUM_THREADS=1 $(PY) benchmarks/bench_massprops.py
	OMP_NUM_THREADS=1 $(PY) benchmarks/bench_yade_build.py
	OMP_NUM_THREADS=1 $(PY) benchmarks/bench_gas.py
