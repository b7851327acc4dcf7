"""Superellipsoid bodies (paper Sec. III-B): support function, signed distance to a plane and its rate, meshes.

Surface, in the superellipsoid frame (eps1 the x-y exponent, eps2 the z one, both in (0, 2]):
``((|x/a|^(2/eps1) + |y/b|^(2/eps1))^(eps1/eps2) + |z/c|^(2/eps2) = 1``. The body is the unit ball of a nested
norm (an l_(2/eps1) norm of (x/a, y/b) inside an l_(2/eps2) norm with z/c), so its support function is the dual
nested norm, with the conjugate exponents q2 = 2/(2 - eps1), q1 = 2/(2 - eps2), of w = (a u_x, b u_y, c u_z):
``h(u) = ((|w_x|^q2 + |w_y|^q2)^(q1/q2) + |w_z|^q1)^(1/q1)`` [m], and grad h(u) is the farthest surface point
along u. A plane ``n.x + D = 0`` (unit n towards the water) is at signed distance ``n.c + D - h(-R^T n)`` from a
body with centre c and rotation R (superellipsoid frame -> world); negative when the body penetrates it.

One CasADi formula serves every caller: the public functions evaluate casadi.Functions, so they return SX/MX
for symbolic arguments and floats / numpy arrays for numeric ones.

Smoothing (finite values, gradients and Hessians everywhere, e.g. for u along an axis): |w| -> sqrt(w^2 + s^2),
which overestimates h by at most 3 s (s = DELTA = 1e-7 m here; the NLPs use ModelOptions.support_smoothing); each
l_q norm is evaluated with its largest term factored out (no under/overflow for large q); q is capped at Q_MAX
(only eps > 1.9998, e.g. eps = 2 where the norm is l_inf), which overestimates h by at most a factor
2^(2/Q_MAX) - 1 = 1.4e-4 (70 um on a 0.5 m body). h is never underestimated: distances err on the safe side.
For box-like bodies (eps < 1, q < 2) the curvature at a face parallel to the plane (w = 0) is of order
s^(q - 2): the default hull facing a wall has d''(yaw) = -b^2 s^(q-2) / a^(q-1), -2.1e4 m/rad^2 at s = 1e-7 m and
-21 m/rad^2 at 1e-3 m (tests/test_superellipsoid.py), within about s / b rad of yaw 0. Evidence for the NLPs'
s: docs/decisions.md, 'Superellipsoids' support function smoothed at 1e-3 m'.
"""

from __future__ import annotations

from functools import cache

import casadi as ca
import numpy as np
import trimesh

DELTA = 1e-7  # m, the default smooth-absolute-value length s: 0 <= h_smoothed - h <= 3 s
Q_MAX = 1e4  # cap on the support exponents q = 2/(2 - eps), reached only for eps > 1.9998

Num = float | np.ndarray
Sym = ca.SX | ca.MX


def _abs(x: ca.SX, s: float) -> ca.SX:
    """Smooth |x| [m]: sqrt(x^2 + s^2), in [|x|, |x| + s]."""
    return ca.sqrt(x**2 + s**2)


def _lq(v1: ca.SX, v2: ca.SX, q: ca.SX) -> ca.SX:
    """(v1^q + v2^q)^(1/q) for positive v, with the largest term factored out (safe for q up to Q_MAX).

    The result does not depend on the factor m (its derivative with respect to m is identically zero), so the
    kink of fmax does not reach the value, the gradient or the Hessian.
    """
    m = ca.fmax(v1, v2)
    return m * ((v1 / m) ** q + (v2 / m) ** q) ** (1 / q)


def _exponent(eps: ca.SX) -> ca.SX:
    """Dual exponent q = 2/(2 - eps) of the l_(2/eps) norm, capped at Q_MAX."""
    return 2 / ca.fmax(2 - eps, 2 / Q_MAX)


@cache
def _functions(smoothing: float = DELTA) -> tuple[ca.Function, ca.Function, ca.Function]:
    """Build (support, plane distance, distance rate) once per smoothing length [m], as SX casadi.Functions."""
    if not smoothing > 0:
        raise ValueError(f"smoothing {smoothing!r} m; allowed: > 0")
    abc, e1, e2, u = ca.SX.sym("abc", 3), ca.SX.sym("eps1"), ca.SX.sym("eps2"), ca.SX.sym("u", 3)
    w = abc * u
    h = _lq(_lq(_abs(w[0], smoothing), _abs(w[1], smoothing), _exponent(e1)), _abs(w[2], smoothing), _exponent(e2))
    support = ca.Function("se_support", [abc, e1, e2, u], [h, ca.gradient(h, u)], ["abc", "eps1", "eps2", "u"],
                          ["h", "point"])

    c, R, n, D = ca.SX.sym("c", 3), ca.SX.sym("R", 3, 3), ca.SX.sym("n", 3), ca.SX.sym("D")
    v, om = ca.SX.sym("v", 3), ca.SX.sym("omega", 3)
    ub = -R.T @ n  # direction, in the superellipsoid frame, of the body point deepest towards the plane
    hb, pb = support(abc, e1, e2, ub)
    dist = ca.Function("se_plane_distance", [abc, e1, e2, c, R, n, D], [ca.dot(n, c) + D - hb],
                       ["abc", "eps1", "eps2", "c", "R", "n", "D"], ["d"])
    # d/dt (R^T n) = -omega x (R^T n) for a body-frame omega, so du/dt = -omega x u and dh/dt = grad h . du/dt.
    rate = ca.Function("se_closing_speed", [abc, e1, e2, R, n, v, om], [ca.dot(n, v) + ca.dot(pb, ca.cross(om, ub))],
                       ["abc", "eps1", "eps2", "R", "n", "v", "omega"], ["d_dot"])
    return support, dist, rate


def _is_symbolic(args: tuple) -> bool:
    return any(isinstance(a, ca.SX | ca.MX) for a in args)


def _check(semi_axes: object, eps1: object, eps2: object) -> None:
    """Raise ValueError on numeric semi-axes that are not positive or exponents outside (0, 2]."""
    for name, val, lo, hi in (("semi_axes", semi_axes, 0.0, np.inf), ("eps1", eps1, 0.0, 2.0),
                              ("eps2", eps2, 0.0, 2.0)):
        if isinstance(val, ca.SX | ca.MX):
            continue
        arr = np.asarray(val, dtype=float)
        if not (np.all(np.isfinite(arr)) and np.all(arr > lo) and np.all(arr <= hi)):
            raise ValueError(f"{name} must be finite and in ({lo}, {hi}], got {val!r}")


def _call(fn: ca.Function, args: tuple) -> list:
    """Evaluate fn; numeric arguments give floats (scalars) or 1-D numpy arrays."""
    _check(*args[:3])
    if _is_symbolic(args):
        return fn(*args) if fn.n_out() > 1 else [fn(*args)]
    out = fn(*[np.asarray(a, dtype=float) for a in args])
    out = out if isinstance(out, tuple | list) else [out]
    return [float(o) if o.numel() == 1 else np.asarray(o).ravel() for o in out]


def support(semi_axes: Num | Sym, eps1: Num | Sym, eps2: Num | Sym, u: Num | Sym, smoothing: float = DELTA
            ) -> float | Sym:
    """Support function h(u) [m]: max of u.x over the body (frame at its centre), u in the superellipsoid frame."""
    return _call(_functions(smoothing)[0], (semi_axes, eps1, eps2, u))[0]


def support_point(semi_axes: Num | Sym, eps1: Num | Sym, eps2: Num | Sym, u: Num | Sym, smoothing: float = DELTA
                  ) -> np.ndarray | Sym:
    """grad h(u) [m]: the surface point farthest along u, in the superellipsoid frame."""
    return _call(_functions(smoothing)[0], (semi_axes, eps1, eps2, u))[1]


def plane_distance(semi_axes: Num | Sym, eps1: Num | Sym, eps2: Num | Sym, center: Num | Sym, R: Num | Sym,
                   normal: Num | Sym, offset: Num | Sym, smoothing: float = DELTA) -> float | Sym:
    """Signed distance [m] from the body (centre [m] and rotation R, world) to the plane n.x + D = 0.

    n is the unit normal towards the free side, D = offset [m]. Negative: the depth of penetration along n.
    `smoothing` [m]: the support function's smoothing length s (module docstring; underestimates d by <= 3 s).
    """
    return _call(_functions(smoothing)[1], (semi_axes, eps1, eps2, center, R, normal, offset))[0]


def closing_speed(semi_axes: Num | Sym, eps1: Num | Sym, eps2: Num | Sym, R: Num | Sym, normal: Num | Sym,
                  velocity: Num | Sym, omega: Num | Sym, smoothing: float = DELTA) -> float | Sym:
    """Time derivative [m/s] of plane_distance (negative when approaching).

    velocity: the centre's world velocity [m/s]; omega: angular velocity in the superellipsoid frame [rad/s].
    """
    return _call(_functions(smoothing)[2], (semi_axes, eps1, eps2, R, normal, velocity, omega))[0]


def _signed_power(t: np.ndarray, e: float) -> np.ndarray:
    """sgn(t) |t|^e, with |t| < 1e-12 (cos(pi/2) in floating point) snapped to zero."""
    t = np.where(np.abs(t) < 1e-12, 0.0, t)
    return np.sign(t) * np.abs(t) ** e


def superellipsoid_mesh(semi_axes: Num, eps1: float, eps2: float, resolution: int = 64) -> trimesh.Trimesh:
    """Watertight, outward-wound triangle mesh of the surface, vertices exactly on it [m].

    Parametric form (eta in [-pi/2, pi/2], omega in [-pi, pi)): x = a C(eta)^eps2 C(om)^eps1,
    y = b C(eta)^eps2 S(om)^eps1, z = c S(eta)^eps2, with C(t)^e = sgn(cos t)|cos t|^e, S(t)^e = sgn(sin t)|sin t|^e.
    resolution: segments around omega (a multiple of 4, so the axis tips are vertices); resolution/2 along eta.
    """
    _check(semi_axes, eps1, eps2)
    if resolution < 8 or resolution % 4:
        raise ValueError(f"resolution must be a multiple of 4 and >= 8, got {resolution}")
    a, b, c = np.asarray(semi_axes, dtype=float)
    n_om, n_eta = resolution, resolution // 2
    eta = -np.pi / 2 + np.pi * np.arange(1, n_eta) / n_eta  # rings without the poles
    om = 2 * np.pi * np.arange(n_om) / n_om
    ce, se = (_signed_power(f(eta), eps2)[:, None] for f in (np.cos, np.sin))
    co, so = (_signed_power(f(om), eps1)[None, :] for f in (np.cos, np.sin))
    ring = np.stack([a * ce * co, b * ce * so, np.broadcast_to(c * se, ce.shape[:1] + co.shape[1:])], axis=-1)
    vertices = np.vstack([ring.reshape(-1, 3), [[0.0, 0.0, -c], [0.0, 0.0, c]]])

    idx = np.arange(ring.shape[0] * n_om).reshape(ring.shape[:2])
    A, B = idx[:-1], np.roll(idx, -1, axis=1)[:-1]
    C, D = np.roll(idx, -1, axis=1)[1:], idx[1:]
    south, north = len(vertices) - 2, len(vertices) - 1
    j, j1 = idx[0], np.roll(idx[0], -1)
    k, k1 = idx[-1], np.roll(idx[-1], -1)
    faces = np.vstack([np.stack([A, B, C], -1).reshape(-1, 3), np.stack([A, C, D], -1).reshape(-1, 3),
                       np.column_stack([np.full(n_om, south), j1, j]),
                       np.column_stack([np.full(n_om, north), k, k1])])
    return trimesh.Trimesh(vertices, faces, process=False)
