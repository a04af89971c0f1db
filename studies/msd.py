"""Deprecated: the MSD is :func:`studies.correlation.msd_fft`; this module keeps the old call
``msd_fft(x, per_particle=False)`` and warns on import."""
from __future__ import annotations

import warnings

import numpy as np

from . import correlation
from .correlation import msd_bruteforce  # noqa: F401

warnings.warn("studies.msd is deprecated: use studies.correlation.msd_fft", DeprecationWarning, stacklevel=2)


def msd_fft(x, per_particle=False):
    """Deprecated: :func:`studies.correlation.msd_fft`; ``per_particle`` gives (T, N)."""
    if not per_particle:
        return correlation.msd_fft(x)
    n_particles = 1 if np.ndim(x) == 2 else np.shape(x)[1]
    return correlation.msd_fft(x, groups=np.arange(n_particles))[1].T
