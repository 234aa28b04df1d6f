"""Differential geometry of the flanks at a contact point, CasADi-generic (SX/MX expressions of the
surface coordinates, or numbers): a tangent basis, the curvature (shape) matrix, and the closed-form
eigen-decomposition of a symmetric 2 x 2 matrix. Shared by the TCA's contact ellipse
(:mod:`gearopt.meshing.tca`) and the slices' curvature across the contact line
(:mod:`gearopt.ltca.slices`)."""

from __future__ import annotations

import casadi as ca

Sym = ca.SX | ca.MX | ca.DM


def shape_matrix(r: Sym, n: Sym, q: Sym, E: Sym) -> Sym:
    """Curvature matrix of a surface in the orthonormal tangent basis ``E`` (3x2):
    ``B = E^T (dn/dr) E`` with the outward normal (convex: positive), via AD."""
    J = ca.jacobian(r, q)  # 3x2
    Nq = ca.jacobian(n, q)  # 3x2
    pinv = ca.solve(ca.mtimes(J.T, J), J.T)  # 2x3
    return ca.mtimes([E.T, Nq, pinv, E])


def unit_perp(n: Sym) -> Sym:
    """A unit vector perpendicular to ``n`` that is smooth where n is far from the z axis' ...
    (for gear flanks n_z is small): ``e = k x n / |k x n|``... oriented along the profile."""
    v = ca.vertcat(-n[1], n[0], 0.0)
    return v / ca.norm_2(v)


def eigh2_sym(K: Sym) -> tuple[Sym, Sym]:
    """Eigenvalues (ascending, (2, 1)) and unit eigenvectors (columns, (2, 2)) of a symmetric 2 x 2
    matrix in closed form (CasADi-generic): with ``m = (a + d) / 2``, ``h = (a - d) / 2``,
    ``r = sqrt(h^2 + b^2)``, the eigenvalues are ``m -+ r`` and the eigenvector of ``m - r`` is
    ``(-sin t, cos t)`` with ``t = atan2(b, h) / 2`` (no cancellation; a multiple of the identity gives
    the axes). Not differentiable where r = 0: for numbers only."""
    a, d, b = K[0, 0], K[1, 1], 0.5 * (K[0, 1] + K[1, 0])
    m, h = 0.5 * (a + d), 0.5 * (a - d)
    r = ca.sqrt(h * h + b * b)
    t = 0.5 * ca.atan2(b, h)
    c, s = ca.cos(t), ca.sin(t)
    return ca.vertcat(m - r, m + r), ca.horzcat(ca.vertcat(-s, c), ca.vertcat(c, s))
