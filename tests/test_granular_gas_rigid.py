"""The isotropic-inertia route for the frictionless dimers equals full rigid-body dynamics.

The study's YADE runs give each two-sphere clump the isotropic inertia I_perp with
``aspherical=False`` (YADE 2023.02a's aspherical integrator is unstable).  Here a dimer
collides with fixed Hertzian obstacles, integrated twice to round-off accuracy in numpy:
(a) the full rigid body, inertia diag(I_axial, I_perp, I_perp) in the body frame, angular
momentum integrated in the world frame; (b) the isotropic body, omega = L / I_perp.  Normal
forces act through the member centres, so with zero initial axial spin both must give the
same centre, axis and angular velocity.  With initial axial spin they must not (control).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from studies import gas_model as gm

MASS, _, I_AX, I_PERP, _ = gm.dimer_properties("exact")
H = gm.CENTRE_DISTANCE / 2
R = gm.R_SPHERE
OBST = np.array([[0.0, 0.0, 0.0], [0.05, 0.45, -0.1]])   # fixed obstacle spheres
R_OBST = 0.1
K_HERTZ = 2.0e5          # N / m^1.5


def rot(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def force_torque(x, u):
    F, T = np.zeros(3), np.zeros(3)
    for s in (-1.0, 1.0):
        c = x + s * H * u
        for o in OBST:
            d = c - o
            dist = np.linalg.norm(d)
            delta = R + R_OBST - dist
            if delta > 0:
                f = K_HERTZ * delta ** 1.5 * d / dist      # normal force through the member centre
                F += f
                T += np.cross(c - x, f)
    return F, T


def rhs(isotropic):
    def f(t, y):
        x, v, q, L = y[:3], y[3:6], y[6:10], y[10:13]
        Rm = rot(q)
        u = Rm[:, 2]                                  # body z = symmetry axis
        if isotropic:
            w = L / I_PERP
        else:
            w = Rm @ (np.array([1 / I_PERP, 1 / I_PERP, 1 / I_AX]) * (Rm.T @ L))
        F, T = force_torque(x, u)
        dq = 0.5 * qmul(np.r_[0.0, w], q)
        return np.r_[v, F / MASS, dq, T]
    return f


def omega(y, isotropic):
    Rm = rot(y[6:10])
    L = y[10:13]
    return L / I_PERP if isotropic else Rm @ (np.array([1 / I_PERP, 1 / I_PERP, 1 / I_AX]) * (Rm.T @ L))


def simulate(axis, w0, isotropic, t_end=0.6):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    # quaternion taking e_z to axis
    c = np.cross([0, 0, 1.0], axis)
    s = np.linalg.norm(c)
    ang = np.arctan2(s, axis[2])
    q = np.r_[np.cos(ang / 2), (np.sin(ang / 2) * c / s) if s > 0 else np.zeros(3)]
    Rm = rot(q)
    Iw = Rm @ np.diag([I_PERP, I_PERP, I_AX]) @ Rm.T
    L0 = (I_PERP * np.eye(3) if isotropic else Iw) @ w0
    y0 = np.r_[[-0.6, -0.02, 0.03], [2.0, 0.3, -0.1], q, L0]
    sol = solve_ivp(rhs(isotropic), (0, t_end), y0, method="DOP853", rtol=1e-11, atol=1e-13, max_step=2e-4)
    assert sol.success
    y = sol.y[:, -1]
    return y[:3], y[3:6], rot(y[6:10])[:, 2], omega(y, isotropic), sol


@pytest.mark.parametrize("axis", [(1, 0.2, 0.3), (0.1, 1, -0.4), (-0.3, 0.5, 1)])
def test_isotropic_route_equals_full_rigid_body(axis):
    w0 = np.zeros(3)                     # the study starts from zero angular velocity
    xf, vf, uf, wf, sol = simulate(axis, w0, isotropic=False)
    xi, vi, ui, wi, _ = simulate(axis, w0, isotropic=True)
    # a real collision happened: translation and rotation changed a lot
    assert np.linalg.norm(wf) > 1.0
    assert np.linalg.norm(vf - [2.0, 0.3, -0.1]) > 0.3
    np.testing.assert_allclose(xi, xf, atol=1e-8)
    np.testing.assert_allclose(vi, vf, atol=1e-8)
    np.testing.assert_allclose(ui, uf, atol=1e-8)
    np.testing.assert_allclose(wi, wf, atol=1e-7)
    assert abs(wf @ uf) < 1e-8           # no axial spin in the exact dynamics


def test_energy_of_full_rigid_body_is_conserved():
    _, vf, uf, wf, sol = simulate((1, 0.2, 0.3), np.zeros(3), isotropic=False)
    Rm = rot(sol.y[6:10, -1])
    Iw = Rm @ np.diag([I_PERP, I_PERP, I_AX]) @ Rm.T
    e0 = 0.5 * MASS * (2.0 ** 2 + 0.3 ** 2 + 0.1 ** 2)
    e1 = 0.5 * MASS * vf @ vf + 0.5 * wf @ Iw @ wf
    assert abs(e1 / e0 - 1) < 1e-8


def test_control_axial_spin_breaks_the_equivalence():
    # must be able to fail: with spin about the symmetry axis the isotropic body is wrong
    axis = np.array([1, 0.2, 0.3]) / np.linalg.norm([1, 0.2, 0.3])
    w0 = 5.0 * axis + np.cross(axis, [0, 0, 1.0])
    _, _, uf, wf, _ = simulate(axis, w0, isotropic=False)
    _, _, ui, wi, _ = simulate(axis, w0, isotropic=True)
    assert np.linalg.norm(ui - uf) > 1e-3 or np.linalg.norm(wi - wf) > 1e-2
