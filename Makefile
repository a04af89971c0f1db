# clumpprops: the README's two commands are `make run` and `make test`.
PY := .venv/bin/python
.PHONY: setup run test bench example
setup:
	@bash scripts/setup.sh
example: setup
	$(PY) examples/paper_dimer.py
run: setup
	$(PY) examples/paper_dimer.py
test: setup
	$(PY) -m pytest -q tests
bench: setup
	$(PY) benchmarks/bench_massprops.py
