"""The out-of-plane (axial) compliance of a gear body as an annular Mindlin plate (docs/ltca.md sections 2 and 7,
"The axial part of a helical load").

A helical member's normal load has the axial part ``sin(beta_b)`` per unit. On the body, a disc of thickness ``b``
(the face width) held at its bore ``r_int`` and free at the root circle ``r_f``, that part bends the disc out of
its plane, and the bending spreads round the whole rim: the teeth ``d`` pitches away move axially by a good part of
the loaded tooth's own axial deflection. The in-plane (plane-stress) body of :mod:`gearopt.ltca.neighbours` (N1)
has no such mode.

The plate is Mindlin's (bending and transverse shear, shear factor 5/6; the disc is about as thick as it is deep,
so shear is not small), each Fourier harmonic ``n`` of the angle solved exactly in the angle and by linear finite
elements in the radius (``w = W(r) cos(n theta)``, rotations ``psi_r = R(r) cos(n theta)``, ``psi_theta = T(r)
sin(n theta)``; the shear energy at one Gauss point per element, against locking). The load is an axial force on
the tooth at ``r_load``, carried to the rim ``r_f`` as a rigid lever (a force and a moment ``P (r_load - r_f)``),
spread over the angle its helix spans across the face, ``b tan(beta) / r_p``; the response is read likewise at
``r_load`` (``w - (r_load - r_f) psi_r``) at the middle of the face of tooth ``d``. Plane tests: the thin limit is
Kirchhoff's annular plate (``tests/test_ltca_plate.py``).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from ..errors import out_of_range

#: Mindlin's shear correction factor
KAPPA = 5.0 / 6.0


def _harmonic_stiffness(n: int, r: np.ndarray, t: float, E: float, nu: float) -> np.ndarray:
    """The stiffness matrix of harmonic ``n`` on the radial nodes ``r`` (DOFs W, R, T per node; T unused for
    n = 0, where it is held), per unit of the harmonic's amplitudes [N/mm]."""
    D = E * t**3 / (12.0 * (1.0 - nu**2))
    Gs = KAPPA * E / (2.0 * (1.0 + nu)) * t
    c = 2.0 * math.pi if n == 0 else math.pi  # int cos^2 = int sin^2 over the circle
    r0, h = r[:-1], np.diff(r)
    ne = h.size
    # per element, the element's 6 DOFs (W0, R0, T0, W1, R1, T1): shape values N and radial derivatives dN
    dN = np.stack([-1.0 / h, 1.0 / h], axis=1)  # (ne, 2)
    Ke = np.zeros((ne, 6, 6))

    def vec(vals, comp):
        out = np.zeros((ne, 6))
        out[:, [comp, comp + 3]] = vals
        return out

    for s, wgt, shear in ((0.5 - 0.5 / math.sqrt(3.0), 0.5, False), (0.5 + 0.5 / math.sqrt(3.0), 0.5, False),
                          (0.5, 1.0, True)):
        N = np.broadcast_to(np.array([1.0 - s, s]), (ne, 2))
        rr = (r0 + s * h)[:, None]
        if shear:  # shear at one Gauss point per element (no locking)
            gr = vec(dN, 0) + vec(N, 1)
            gt = -n * vec(N, 0) / rr + vec(N, 2)
            B = Gs * (gr[:, :, None] * gr[:, None, :] + gt[:, :, None] * gt[:, None, :])
        else:  # bending, two Gauss points
            kr = vec(dN, 1)
            kt = (vec(N, 1) + n * vec(N, 2)) / rr
            krt = -n * vec(N, 1) / rr + vec(dN, 2) - vec(N, 2) / rr
            B = D * (kr[:, :, None] * kr[:, None, :] + kt[:, :, None] * kt[:, None, :]
                     + nu * (kr[:, :, None] * kt[:, None, :] + kt[:, :, None] * kr[:, None, :])
                     + 0.5 * (1.0 - nu) * krt[:, :, None] * krt[:, None, :])
        Ke += (c * wgt * h * rr[:, 0])[:, None, None] * B
    K = np.zeros((3 * r.size, 3 * r.size))
    for e in range(ne):
        K[3 * e:3 * e + 6, 3 * e:3 * e + 6] += Ke[e]
    return K


@lru_cache(maxsize=256)
def _edge_flexibility(n: int, a: float, b: float, t: float, E: float, nu: float, n_el: int) -> np.ndarray:
    """The 2 x 2 flexibility of harmonic ``n`` between the rim's (W, R) [mm/N, 1/N, 1/(N mm)]: the plate held
    (W = R = T = 0) at ``a``, free at ``b``."""
    r = a + (b - a) * (1.0 - np.cos(np.linspace(0.0, math.pi / 2, n_el + 1)))  # finer towards the rim
    K = _harmonic_stiffness(n, r, t, E, nu)
    free = np.arange(3, 3 * r.size)
    if n == 0:
        free = free[free % 3 != 2]
    rim = [3 * (r.size - 1), 3 * (r.size - 1) + 1]
    pos = [int(np.flatnonzero(free == i)[0]) for i in rim]
    Kf = K[np.ix_(free, free)]
    rhs = np.zeros((free.size, 2))
    rhs[pos[0], 0] = rhs[pos[1], 1] = 1.0
    # symmetric positive definite and banded (half bandwidth 5): LAPACK's banded Cholesky (scipy
    # imported here: a spur drive, or a helical one whose compliance is cached, never needs it, and
    # importing scipy.linalg costs ~0.13 s of every process's start)
    from scipy.linalg import solveh_banded

    u = 5
    ab = np.zeros((u + 1, free.size))
    for k in range(u + 1):
        ab[u - k, k:] = np.diagonal(Kf, k)
    X = solveh_banded(ab, rhs)
    return X[pos, :]


def _check(a: float, b: float, t: float) -> None:
    if not 0.0 < a < b:
        raise out_of_range("a", f"{a:g} mm", f"0 < a < b = {b:g} mm (the bore inside the rim)")
    if not t > 0.0:
        raise out_of_range("t", f"{t:g} mm", "t > 0 mm")


def rim_flexibility(a: float, b: float, t: float, angles: npt.ArrayLike, spread: float = 0.0, E: float = 210e3, nu: float = 0.3,
                    n_max: int = 80, n_el: int = 48) -> np.ndarray:
    """The rim's flexibility between a unit axial force and moment at angle 0 and the axial displacement and
    rotation ``(w, psi_r)`` at the polar ``angles`` [rad]: (len(angles), 2, 2) [mm/N, 1/N; 1/N, 1/(N mm)].
    ``v^T F v`` with ``v = (1, -lever)`` is :func:`axial_response` (parameters there)."""
    _check(a, b, t)
    ang = np.asarray(angles, float).reshape(-1)
    out = np.zeros((ang.size, 2, 2))
    for n in range(n_max + 1):
        F = _edge_flexibility(n, float(a), float(b), float(t), float(E), float(nu), int(n_el))
        sinc = 1.0 if n == 0 or spread == 0.0 else math.sin(0.5 * n * spread) / (0.5 * n * spread)
        # a unit force at angle 0 has the harmonic amplitudes 1 / (2 pi) (n = 0) and 1 / pi, per unit of the
        # energy's angular integral (c in _harmonic_stiffness), i.e. a generalized force of 1 on every harmonic
        out += (sinc * np.cos(n * ang))[:, None, None] * F[None]
    return out


def axial_response(a: float, b: float, t: float, angles: npt.ArrayLike, lever: float = 0.0, spread: float = 0.0,
                   E: float = 210e3, nu: float = 0.3, n_max: int = 80, n_el: int = 48) -> np.ndarray:
    """Axial displacement [mm/N] at the polar ``angles`` [rad] under a unit axial force at angle 0.

    Parameters
    ----------
    a, b : float
        The plate's inner (held) and outer (free) radii [mm], ``0 < a < b``.
    t : float
        Its thickness [mm].
    angles : array_like
        Where the displacement is read [rad], on the rim (plus ``lever``).
    lever : float
        The radial distance [mm] from the rim to where the force acts and the displacement is read (a rigid
        lever: force ``P`` and moment ``P lever`` on the rim; displacement ``w - lever psi_r``).
    spread : float
        The force spread uniformly over this angle [rad] centred on 0 (a helix across the face); 0: a point.
    E, nu : float
        Young's modulus [MPa] and Poisson's ratio.
    n_max : int
        The highest harmonic.
    n_el : int
        Radial elements per harmonic.

    Raises
    ------
    GeometryError
        ``a`` not in ``0 < a < b``, or ``t <= 0``.
    """
    F = rim_flexibility(a, b, t, angles, spread, E, nu, n_max, n_el)
    v = np.array([1.0, -lever])
    return np.einsum("i,aij,j->a", v, F, v)


__all__ = ["KAPPA", "axial_response", "rim_flexibility"]
