"""The immutable answer: :class:`MassProperties`, and the step every method shares.

Each method computes three volume moments of the clump about a per-clump origin o
(see ``_input``): the volume V = int dV, the first moment S = int (x - o) dV and the
second moment Q = int (x - o)(x - o)^T dV.  :func:`finish` turns them into mass,
centre of mass and the inertia tensor about the centre of mass,

    m = rho V,   r_cm = o + S / V,   I = rho [tr(Q_c) 1 - Q_c],   Q_c = Q - S S^T / V,

which is the paper's eq. (7) (the parallel-axis sum) written for continuous bodies,
then diagonalises I (the paper's principal-axis transformation after eq. (7)):
``inertia == principal_axes @ diag(principal_moments) @ principal_axes.T`` with
ascending moments and a right-handed orthonormal axes matrix (columns are axes), so
the matrix is the paper's J: u_inertial = J u_body.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Optional

import numpy as np


def _frozen(a):
    """Read-only float64 array (copied unless already read-only float64); 0-d becomes a float."""
    if not (isinstance(a, np.ndarray) and a.dtype == np.float64 and not a.flags.writeable):
        a = np.array(a, dtype=np.float64, copy=True)
    if a.ndim == 0:
        return float(a)
    a.setflags(write=False)
    return a


def _seal(*arrays):
    for a in arrays:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)


@dataclass(frozen=True)
class StandardError:
    """One-sigma standard errors of a sampled (Monte Carlo) estimate, same shapes as the values.

    ``mass`` in kg, ``volume`` in m^3, ``center_of_mass`` in m, ``inertia`` in kg m^2
    (element-wise, delta method for the ratio estimators).
    """

    mass: np.ndarray
    volume: np.ndarray
    center_of_mass: np.ndarray
    inertia: np.ndarray

    def __post_init__(self):
        for f in fields(self):
            object.__setattr__(self, f.name, _frozen(getattr(self, f.name)))

    def __getitem__(self, idx):
        return StandardError(*(getattr(self, f.name)[idx] for f in fields(self)))


@dataclass(frozen=True)
class MassProperties:
    """Mass properties of one clump, or of a batch of M clumps (leading axis M).

    Attributes (SI units; shapes for one clump, prefixed by (M,) for a batch):

    ``mass`` kg, ``volume`` m^3, ``center_of_mass`` (3,) m,
    ``inertia`` (3, 3) kg m^2 about the centre of mass in the input axes,
    ``principal_moments`` (3,) kg m^2 ascending, ``principal_axes`` (3, 3) orthonormal,
    right-handed, columns are the axes,
    ``method`` the method that produced them, ``density`` kg/m^3,
    ``standard_error`` a :class:`StandardError` for sampled methods, else None.

    Instances are immutable (arrays are read-only); index a batch with ``mp[i]``.
    """

    mass: np.ndarray
    volume: np.ndarray
    center_of_mass: np.ndarray
    inertia: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    method: str
    density: float
    standard_error: Optional[StandardError] = field(default=None, compare=False)

    _ARRAYS = ("mass", "volume", "center_of_mass", "inertia", "principal_moments", "principal_axes")

    def __post_init__(self):
        for name in self._ARRAYS:
            object.__setattr__(self, name, _frozen(getattr(self, name)))

    @property
    def batched(self) -> bool:
        return np.ndim(self.mass) == 1

    def __len__(self):
        if not self.batched:
            raise TypeError("a single clump's MassProperties has no len(); it is not a batch")
        return len(self.mass)

    def __getitem__(self, idx):
        if not self.batched:
            raise TypeError("a single clump's MassProperties cannot be indexed")
        se = None if self.standard_error is None else self.standard_error[idx]
        return MassProperties(
            *(getattr(self, n)[idx] for n in self._ARRAYS),
            method=self.method,
            density=self.density,
            standard_error=se,
        )

    def to_dict(self) -> dict:
        """Plain-Python view (lists and floats), e.g. for JSON."""
        d = {n: np.asarray(getattr(self, n)).tolist() for n in self._ARRAYS}
        d["method"] = self.method
        d["density"] = self.density
        if self.standard_error is not None:
            d["standard_error"] = {
                f.name: np.asarray(getattr(self.standard_error, f.name)).tolist() for f in fields(StandardError)
            }
        return d


def principal(inertia: np.ndarray):
    """Ascending principal moments (..., 3) and right-handed axes (..., 3, 3) of symmetric (..., 3, 3)."""
    w, v = np.linalg.eigh(inertia)
    det = np.einsum("...i,...i->...", np.cross(v[..., :, 0], v[..., :, 1]), v[..., :, 2])
    v[..., :, 2] *= np.where(det < 0, -1.0, 1.0)[..., None]
    return w, v


def inertia_from_second_moment(Qc: np.ndarray, density: float) -> np.ndarray:
    """I = rho (tr(Q_c) 1 - Q_c) for central second moments Q_c (..., 3, 3)."""
    tr = np.trace(Qc, axis1=-2, axis2=-1) * density
    I = 0.5 * (Qc + np.swapaxes(Qc, -1, -2))
    I *= -density
    for k in range(3):
        I[..., k, k] += tr
    return I


def finish(V, S, Q, origin, density, method, batched, standard_error=None) -> MassProperties:
    """Build :class:`MassProperties` from volume moments about the per-clump origin (see module doc)."""
    V = np.asarray(V, dtype=np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        finite = np.isfinite(V).all() and np.isfinite(S).all() and np.isfinite(Q).all() and np.isfinite(Q * density).all()
    if not finite:
        raise ValueError(
            "the clump's moments overflow float64 (input too large: radius^5 * density must stay "
            "below ~1e308 in SI units); rescale the input"
        )
    if np.any(V <= 0):
        raise ArithmeticError(f"internal error in method {method!r}: non-positive volume {V}")
    d = S / V[:, None]
    Qc = Q
    Qc -= S[:, :, None] * d[:, None, :]
    I = inertia_from_second_moment(Qc, density)
    w, axes = principal(I)
    com = origin + d
    mass = density * V
    _seal(mass, V, com, I, w, axes)  # fresh arrays owned here: freeze without copying
    if not batched:
        mass, V, com, I, w, axes = mass[0], V[0], com[0], I[0], w[0], axes[0]
        if standard_error is not None:
            standard_error = standard_error[0]
    return MassProperties(mass, V, com, I, w, axes, method=method, density=float(density), standard_error=standard_error)
