"""pytest configuration: the hypothesis profile (tests/_profiles.py; default ``ci``, derandomized),
and the markers ``library``, ``yade`` and ``slow``.

``library`` marks the tests of the library alone (geometry, the compiled core, input validation,
the command line and the file formats): they need nothing but an installed ``clumpprops`` and the
test requirements (``pip install clumpprops[test]``), no YADE, no other engine, no study, no
results.  ``pytest -m library`` runs them (``make test-fast``; ``make test-wheel`` runs them
against a wheel built from the sdist, installed in a fresh venv).

``yade`` marks the test files that run YADE (in process or as a subprocess, natively or in the
Debian 13 root); ``slow`` the files whose tests run gases, sweeps or reports and take seconds to
minutes each.  ``pytest -m "not yade and not slow"`` is the quick loop for study and theory code;
``make test`` runs everything.
"""
import os

import _profiles

_profiles.load()

LIBRARY = {
    "test_adversarial.py", "test_audit.py", "test_audit_stated.py", "test_baselines.py", "test_batching.py", "test_cli.py", "test_core.py", "test_core_dense.py", "test_core_header.py",
    "test_exact.py", "test_exact_degenerate.py", "test_exact_reference.py", "test_export_safety.py", "test_fuzz_exact.py",
    "test_invariance.py", "test_io.py", "test_io_fast.py", "test_mesh.py", "test_packaging.py", "test_pairwise_physics.py", "test_pairwise_refusal.py",
    "test_shape.py", "test_shape_cli.py", "test_show.py", "test_validation.py",
    "test_value_object.py",
    "test_io_formats.py",
    "test_fit.py",
}


YADE = {
    "test_baselines_yade.py", "test_debian13_unprivileged.py", "test_decks_yade.py", "test_engine_yade_export.py", "test_kinetic.py",
    "test_hcs_yade.py", "test_study_analysis.py", "test_study_engine.py", "test_timestep.py", "test_yade_adapter.py", "test_yade_dynamics.py",
    "test_yade_executable.py", "test_yade_guards.py", "test_yade_lifecycle.py", "test_yade_registry.py",
    "test_predict.py", "test_predict_cooling.py",
}

SLOW = {
    "test_audit_liggghts.py", "test_decks.py", "test_granular_gas_rigid.py", "test_gk_sensitivity.py", "test_hcs_yade.py",
    "test_kinetic.py", "test_report.py", "test_study_analysis.py",
    "test_study_engine.py", "test_sweep_script.py", "test_timestep.py", "test_yade_registry.py",
    "test_predict.py", "test_predict_cooling.py",
}

MARKERS = {"library": LIBRARY, "yade": YADE, "slow": SLOW}


def pytest_configure(config):
    config.addinivalue_line("markers", "library: the library's own tests (no YADE, engines, studies or results)")
    config.addinivalue_line("markers", "yade: tests that run YADE")
    config.addinivalue_line("markers", "slow: tests that take seconds to minutes each (gases, sweeps, reports)")


def pytest_collection_modifyitems(config, items):
    for item in items:
        name = os.path.basename(str(item.fspath))
        for marker, files in MARKERS.items():
            if name in files:
                item.add_marker(marker)
