"""Deprecated: the estimators live in :mod:`studies.correlation` (VACF, MSD), :mod:`studies.diffusion`
(Green-Kubo and MSD-slope D), :mod:`studies.intervals` (intervals across runs), :mod:`studies.synthetic`
(OU walkers, equipartition spins), :mod:`studies.equilibration` and :mod:`studies.sequential`.
This module re-exports their names for code written against it and warns on import."""
from __future__ import annotations

import warnings

from .correlation import group_labels, msd_fft, vacf_bruteforce, vacf_fft  # noqa: F401
from .diffusion import (GK_C_TRUNC, GK_FIT_WINDOW, correlation_time, diffusion_green_kubo,  # noqa: F401
                        green_kubo_interval, green_kubo_jackknife, green_kubo_stderr, initial_decay_time,
                        ols_msd, ols_msd_stderr, vacf_integral)
from .equilibration import detect_equilibration  # noqa: F401
from .sequential import MIN_PAIRS, next_batch, pairs_needed, sequential_status  # noqa: F401
from .intervals import fieller_from_means, fieller_ratio, ratio_of_means, t_interval  # noqa: F401
from .intervals import t_quantile as _tq  # noqa: F401
from .synthetic import equipartition_angular_velocities, simulate_ou  # noqa: F401

warnings.warn("studies.estimators is deprecated: import from studies.correlation, studies.diffusion, studies.intervals, "
              "studies.synthetic, studies.equilibration or studies.sequential", DeprecationWarning, stacklevel=2)


def msd_fft_groups(pos, max_lag_frames, groups=None):
    """Deprecated name of :func:`studies.correlation.msd_fft` with a lag limit."""
    return msd_fft(pos, max_lag_frames, groups)
