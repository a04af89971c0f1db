"""YADE access for the adapter: the lazy loader ``_Y``, the adapter's error, and calls of YADE's own
``O.bodies`` methods whatever guards are installed.

YADE is imported on first use (``_Y.load()``), never when ``clumpprops.yade`` is imported, so the
adapter works both in scripts run by the ``yade`` executable and after a plain ``import yade``.
Loading YADE changes nothing in it: the guards on ``O.bodies`` are installed only by
:func:`clumpprops.yade.install_guards`.
"""
from __future__ import annotations

import warnings

import numpy as np


class ClumpAdapterError(ValueError):
    """Bad input to the YADE adapter; the message names the offending body id.

    A :class:`ValueError`, raised before anything in the scene is modified.  Also raised where
    YADE refuses an operation the adapter asks of it (its warning becomes the message), and where
    YADE's state after a build differs from the target.
    """


class _Y:
    """The handful of YADE objects used here, imported on first use."""

    _loaded = False

    @classmethod
    def load(cls):
        if not cls._loaded:
            try:
                import yade  # noqa: F401  (initialises YADE on a plain import)
            except ModuleNotFoundError as e:
                if e.name != "yade":
                    raise
                raise ModuleNotFoundError(
                    "clumpprops.yade needs YADE, which is not on PyPI: install Debian's or Ubuntu's `yade` package "
                    "and run with its Python (`yade -x script.py`, or /usr/bin/python3 with YADE's py folder on "
                    "sys.path; docs/yade_adapter.md)", name="yade") from None
            from yade import wrapper
            from yade.minieigenHP import Matrix3, Quaternion, Vector3

            cls.O = yade.O
            cls.Body = wrapper.Body
            cls.Shape = wrapper.Shape
            cls.State = wrapper.State
            cls.Sphere = wrapper.Sphere
            cls.Clump = wrapper.Clump
            cls.Vector3 = Vector3
            cls.Quaternion = Quaternion
            cls.Matrix3 = Matrix3
            cls._loaded = True
        return cls


def _vec(v):
    return np.array([float(v[0]), float(v[1]), float(v[2])])


def _rotation(q):
    """Rotation matrix (numpy) of a minieigen quaternion."""
    m = q.toRotationMatrix()
    return np.array([[float(m[i, j]) for j in range(3)] for i in range(3)])


_RAW = {}  # name -> YADE's own BodyContainer method, recorded by install_guards before it replaces it


def _yade_method(Y, name):
    """YADE's own ``BodyContainer.<name>``, whether or not a guard replaces it."""
    return _RAW.get(name) or getattr(type(Y.O.bodies), name)


def _raw(Y, name, *args, what, **kw):
    """Call YADE's own ``O.bodies.<name>`` (not the guard) and turn a refusal into an error.

    YADE reports a refused release/add as a Python warning ("Body 3 not released from clump 2,
    because ...", "... Body was not added.") and carries on; here that raises
    :class:`ClumpAdapterError` naming ``what``.
    """
    fn = _yade_method(Y, name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ret = fn(Y.O.bodies, *args, **kw)
    for w in caught:
        msg = str(w.message)
        if msg.startswith("Warning") or "not released" in msg or "not added" in msg:
            raise ClumpAdapterError(f"{what}: YADE refused O.bodies.{name}: {msg}")
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return ret
