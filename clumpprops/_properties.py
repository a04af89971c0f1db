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

from .core import _core


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
    """One-sigma standard errors of a sampled (Monte Carlo) estimate.

    Each field has the shape of the value it belongs to in :class:`MassProperties` and is stored
    as a read-only float64 array (a float for a 0-d value).  ``se[i]`` gives the errors of
    clump ``i`` of a batch.

    Parameters
    ----------
    mass : float or array_like, shape () or (M,)
        Standard error of the mass, in kg.
    volume : float or array_like, shape () or (M,)
        Standard error of the volume, in m^3.
    center_of_mass : array_like, shape (3,) or (M, 3)
        Standard error of each coordinate of the centre of mass, in m.
    inertia : array_like, shape (3, 3) or (M, 3, 3)
        Standard error of each element of the inertia tensor about the centre of mass, in
        kg m^2.

    Notes
    -----
    The errors are element-wise; those of the centre of mass and the inertia (ratio
    estimators) follow from the delta method.
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


@dataclass(frozen=True, eq=False)
class MassProperties:
    """Mass properties of one clump, or of a batch of M clumps (leading axis M).

    Made by :func:`clumpprops.mass_properties`.  Every parameter is an attribute of the same
    name.  Shapes are those of one clump; a batch prefixes each array with (M,).

    Parameters
    ----------
    mass : float or array_like, shape () or (M,)
        Mass, in kg.
    volume : float or array_like, shape () or (M,)
        Volume of the union of the spheres, in m^3.
    center_of_mass : array_like, shape (3,) or (M, 3)
        Centre of mass in the input axes, in m.
    inertia : array_like, shape (3, 3) or (M, 3, 3)
        Inertia tensor about the centre of mass, in the input axes, in kg m^2.
    principal_moments : array_like, shape (3,) or (M, 3)
        Principal moments of inertia, ascending, in kg m^2.
    principal_axes : array_like, shape (3, 3) or (M, 3, 3)
        Principal axes as the columns of an orthonormal, right-handed matrix:
        ``inertia == principal_axes @ diag(principal_moments) @ principal_axes.T``.
    method : str
        Name of the method that produced the values (``"exact"``, ``"pairwise"``, ...).
    density : float
        Solid density of the member spheres, in kg/m^3.
    standard_error : StandardError or None, optional
        One-sigma errors for a sampled method (``"montecarlo"``), else None.

    Notes
    -----
    Instances are immutable (every array is read-only float64); index a batch with
    ``mp[i]`` and iterate over its clumps with ``for p in mp``.

    A value object: ``==`` and ``hash`` compare the defining values exactly (mass, volume,
    centre of mass, inertia, method, density; -0.0 equals 0.0); principal moments and axes
    are derived from the inertia (and the axes are not unique for equal moments), and the
    standard error is metadata, so neither takes part.  Use :meth:`allclose` for
    tolerances.  :meth:`translated`, :meth:`rotated` and :meth:`inertia_about` give the
    properties of the moved body or about another point; :attr:`orientation` is the
    principal frame as a ``scipy.spatial.transform.Rotation``; :func:`concatenate` stacks.
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
    _DEFINING = ("mass", "volume", "center_of_mass", "inertia")

    def __post_init__(self):
        for name in self._ARRAYS:
            object.__setattr__(self, name, _frozen(getattr(self, name)))

    @classmethod
    def _make(cls, mass, volume, com, inertia, moments, axes, method, density, standard_error=None):
        """Build from arrays that are already read-only float64 (the core's output): no copies."""
        self = object.__new__(cls)
        d = self.__dict__
        d["mass"], d["volume"], d["center_of_mass"], d["inertia"] = mass, volume, com, inertia
        d["principal_moments"], d["principal_axes"] = moments, axes
        d["method"], d["density"], d["standard_error"] = method, density, standard_error
        return self

    @property
    def batched(self) -> bool:
        """True for a batch of clumps (``mass`` has shape (M,)), False for one clump."""
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

    def __iter__(self):
        return (self[i] for i in range(len(self)))

    # ------------------------------------------------------------ value semantics
    def __eq__(self, other):
        if not isinstance(other, MassProperties):
            return NotImplemented
        if self.method != other.method or self.density != other.density:
            return False
        for n in self._DEFINING:
            a, b = getattr(self, n), getattr(other, n)
            if np.shape(a) != np.shape(b) or not np.array_equal(a, b):
                return False
        return True

    def __ne__(self, other):
        eq = self.__eq__(other)
        return eq if eq is NotImplemented else not eq

    def __hash__(self):
        parts = [self.method, self.density + 0.0]
        for n in self._DEFINING:
            a = np.asarray(getattr(self, n), dtype=np.float64) + 0.0  # -0.0 -> 0.0, as == does
            parts.append((a.shape, a.tobytes()))
        return hash(tuple(parts))

    def allclose(self, other: "MassProperties", rtol: float = 1e-9, atol: float = 0.0) -> bool:
        """Whether every defining value agrees with ``other`` within a tolerance.

        Parameters
        ----------
        other : MassProperties
            The properties to compare with (one clump, or a batch of the same length).
        rtol : float, optional
            Relative tolerance, applied to the scale of each quantity (see Notes).
        atol : float, optional
            Absolute tolerance, in the quantity's own SI unit (kg, m^3, m, kg m^2).

        Returns
        -------
        bool
            True if mass, volume, centre of mass and inertia agree within
            ``atol + rtol * scale`` for every clump; False otherwise, and for batches of
            different shapes.

        Raises
        ------
        TypeError
            If ``other`` is not a :class:`MassProperties`.

        Notes
        -----
        Scales: mass and volume their own magnitude; the centre of mass the clump's radius of
        gyration sqrt(tr(I) / (2 m)) (so translating a clump far away does not loosen the test);
        the inertia its largest element.  Method and density are not compared (results of
        different methods can be close).
        """
        if not isinstance(other, MassProperties):
            raise TypeError(f"allclose needs a MassProperties, got {type(other).__name__}")
        if np.shape(self.mass) != np.shape(other.mass):
            return False
        m, mo = np.asarray(self.mass), np.asarray(other.mass)
        I, Io = np.asarray(self.inertia), np.asarray(other.inertia)
        tr = np.trace(I, axis1=-2, axis2=-1)
        L = np.sqrt(np.abs(tr) / (2.0 * np.abs(m)))

        def close(a, b, scale):
            return bool(np.all(np.abs(a - b) <= atol + rtol * scale))

        return (
            close(m, mo, np.abs(m))
            and close(np.asarray(self.volume), np.asarray(other.volume), np.abs(np.asarray(self.volume)))
            and close(self.center_of_mass, other.center_of_mass, L[..., None])
            and close(I, Io, np.max(np.abs(I), axis=(-2, -1))[..., None, None])
        )

    # ------------------------------------------------------------ moved bodies
    def translated(self, v) -> "MassProperties":
        """The same body moved by a translation.

        Parameters
        ----------
        v : array_like, shape (3,) or (M, 3)
            Translation, in m: one for every clump, or one per clump of a batch.

        Returns
        -------
        MassProperties
            The moved body: the centre of mass moves by ``v``; mass, volume, the inertia
            (about the centre of mass), the principal frame and the standard error are kept.

        Raises
        ------
        ValueError
            If ``v`` has another shape, or contains NaN or inf.
        """
        v = np.asarray(v, dtype=np.float64)
        if v.shape not in ((3,), np.shape(self.center_of_mass)):
            raise ValueError(f"translation must have shape (3,) or {np.shape(self.center_of_mass)}, got {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError("translation contains NaN or inf")
        return MassProperties(self.mass, self.volume, self.center_of_mass + v, self.inertia, self.principal_moments,
                              self.principal_axes, method=self.method, density=self.density,
                              standard_error=self.standard_error)

    def rotated(self, rotation) -> "MassProperties":
        """The body rotated about the world origin.

        Parameters
        ----------
        rotation : array_like, shape (3, 3), or scipy.spatial.transform.Rotation
            A proper rotation: an orthonormal matrix with determinant +1, or a single
            ``Rotation``.  The same rotation applies to every clump of a batch.

        Returns
        -------
        MassProperties
            The rotated body: centre of mass ``R c``, inertia ``R I R^T``, principal axes
            ``R J``; mass, volume and principal moments are kept.  ``standard_error`` is None.

        Raises
        ------
        ValueError
            If ``rotation`` is not a (3, 3) matrix or a single Rotation, or not a proper
            rotation (orthonormal to 1e-10, determinant +1).

        Notes
        -----
        The standard error of a sampled result is element-wise in the input axes and does not
        rotate with the body, so the result has none.
        """
        R = _rotation_matrix(rotation)
        com = self.center_of_mass @ R.T
        I = R @ self.inertia @ R.T
        I = 0.5 * (I + np.swapaxes(I, -1, -2))
        axes = R @ self.principal_axes
        return MassProperties(self.mass, self.volume, com, I, self.principal_moments, axes,
                              method=self.method, density=self.density)

    def inertia_about(self, point) -> np.ndarray:
        """Inertia tensor about another point, axes parallel to the input axes.

        Parameters
        ----------
        point : array_like, shape (3,) or (M, 3)
            The reference point, in m: one for every clump, or one per clump of a batch.

        Returns
        -------
        numpy.ndarray, shape (3, 3) or (M, 3, 3)
            The inertia tensor about ``point``, in kg m^2.

        Raises
        ------
        ValueError
            If ``point`` has another shape.

        Notes
        -----
        Parallel-axis theorem: ``I_com + m (|d|^2 1 - d d^T)`` with ``d = com - point``.
        """
        p = np.asarray(point, dtype=np.float64)
        if p.shape not in ((3,), np.shape(self.center_of_mass)):
            raise ValueError(f"point must have shape (3,) or {np.shape(self.center_of_mass)}, got {p.shape}")
        d = self.center_of_mass - p
        m = np.asarray(self.mass)[..., None, None]
        sq = np.einsum("...i,...i->...", d, d)[..., None, None]
        return self.inertia + m * (sq * np.eye(3) - d[..., :, None] * d[..., None, :])

    @property
    def orientation(self):
        """The principal frame as a ``scipy.spatial.transform.Rotation`` (body to input axes).

        ``orientation.as_matrix() == principal_axes`` (right-handed), so
        ``inertia == R diag(principal_moments) R^T``.  A stacked Rotation for a batch.
        """
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(np.array(self.principal_axes))  # scipy 1.10 needs a writeable buffer

    def to_dict(self) -> dict:
        """Plain-Python view of the values, e.g. for JSON.

        Returns
        -------
        dict
            The arrays as (nested) lists of floats, keyed by attribute name (SI units), with
            ``method``, ``density`` and, for a sampled result, ``standard_error`` as a dict of
            the same form.
        """
        d = {n: np.asarray(getattr(self, n)).tolist() for n in self._ARRAYS}
        d["method"] = self.method
        d["density"] = self.density
        if self.standard_error is not None:
            d["standard_error"] = {
                f.name: np.asarray(getattr(self.standard_error, f.name)).tolist() for f in fields(StandardError)
            }
        return d


def _rotation_matrix(rotation) -> np.ndarray:
    if hasattr(rotation, "as_matrix") and not isinstance(rotation, np.ndarray):
        R = np.asarray(rotation.as_matrix(), dtype=np.float64)
    else:
        R = np.asarray(rotation, dtype=np.float64)
    if R.shape != (3, 3):
        raise ValueError(f"rotation must be a (3, 3) matrix or a single scipy Rotation, got shape {R.shape}")
    if not np.all(np.isfinite(R)) or np.max(np.abs(R @ R.T - np.eye(3))) > 1e-10 or np.linalg.det(R) < 0:
        raise ValueError("rotation must be a proper rotation matrix (orthonormal, det +1)")
    return R


def concatenate(items) -> MassProperties:
    """Stack mass properties (single clumps or batches) into one batch, in order.

    Parameters
    ----------
    items : iterable of MassProperties
        Results of one method and one density (the batch has one of each); single clumps and
        batches may be mixed.

    Returns
    -------
    MassProperties
        A batch with the clumps of ``items`` in order.  It has a standard error if every item
        has one, else None.

    Raises
    ------
    ValueError
        If ``items`` is empty, or the items differ in method or density.
    TypeError
        If an item is not a :class:`MassProperties`.
    """
    items = list(items)
    if not items:
        raise ValueError("concatenate needs at least one MassProperties")
    for x in items:
        if not isinstance(x, MassProperties):
            raise TypeError(f"concatenate takes MassProperties, got {type(x).__name__}")
    m0, d0 = items[0].method, items[0].density
    if any(x.method != m0 or x.density != d0 for x in items):
        raise ValueError("concatenate needs results of one method and one density "
                         f"(got {sorted({(x.method, x.density) for x in items})})")

    def stack(name, src):
        return np.concatenate([np.asarray(getattr(x, name))[None] if not x.batched else np.asarray(getattr(x, name))
                               for x in src])

    se = None
    if all(x.standard_error is not None for x in items):
        ses = [x.standard_error for x in items]
        se = StandardError(*(np.concatenate([np.asarray(getattr(s, f.name))[None] if not x.batched
                                             else np.asarray(getattr(s, f.name)) for s, x in zip(ses, items)])
                             for f in fields(StandardError)))
    return MassProperties(*(stack(n, items) for n in MassProperties._ARRAYS), method=m0, density=d0, standard_error=se)


def principal(inertia: np.ndarray):
    """Ascending principal moments (..., 3) and right-handed axes (..., 3, 3) of symmetric (..., 3, 3)."""
    I = np.ascontiguousarray(inertia, dtype=np.float64)
    w = np.empty(I.shape[:-1])
    v = np.empty(I.shape)
    _core.principal(I, w, v)  # Jacobi in the core, as for the core's own methods
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
