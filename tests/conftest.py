"""pytest configuration: the hypothesis profile (tests/_profiles.py; default ``ci``, derandomized),
and the ``library`` marker.

``library`` marks the tests of the library alone (geometry, the compiled core, input validation,
the command line and the file formats): they need nothing but an installed ``clumpprops`` and the
test requirements (``pip install clumpprops[test]``), no YADE, no other engine, no study, no
results.  ``pytest -m library`` runs them (``make test-fast``; ``make test-wheel`` runs them
against a wheel built from the sdist, installed in a fresh venv).
"""
import os

import _profiles

_profiles.load()

LIBRARY = {
    "test_adversarial.py", "test_baselines.py", "test_batching.py", "test_cli.py", "test_core.py", "test_core_header.py",
    "test_exact.py", "test_exact_degenerate.py", "test_exact_reference.py", "test_export_safety.py", "test_fuzz_exact.py",
    "test_invariance.py", "test_io.py", "test_io_fast.py", "test_packaging.py", "test_pairwise_physics.py", "test_pairwise_refusal.py",
    "test_validation.py",
    "test_value_object.py",
}


def pytest_configure(config):
    config.addinivalue_line("markers", "library: the library's own tests (no YADE, engines, studies or results)")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if os.path.basename(str(item.fspath)) in LIBRARY:
            item.add_marker("library")
