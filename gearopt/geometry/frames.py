"""Rotations and frames in one place (docs/theory.md section 1).

CasADi-generic rotations of one vector (``ca.SX``, ``ca.MX``, ``ca.DM`` or floats), used inside the
expression graphs (generation, TCA), and numpy versions that rotate arrays of points (FE meshes,
plots). Every rotation is right-handed (counter-clockwise seen from the positive axis).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from ..types import ArrayLike, Expr


def rot_x(angle: Expr, v: Expr) -> Expr:
    """``v`` (3,) turned by ``angle`` [rad] about x (CasADi-generic)."""
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(v[0], c * v[1] - s * v[2], s * v[1] + c * v[2])


def rot_y(angle: Expr, v: Expr) -> Expr:
    """``v`` (3,) turned by ``angle`` [rad] about y (CasADi-generic)."""
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2])


def rot_z(angle: Expr, v: Expr) -> Expr:
    """``v`` (3,) turned by ``angle`` [rad] about z (CasADi-generic)."""
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


def rot_z_points(P: ArrayLike, angle: float) -> np.ndarray:
    """Points ``P`` (..., 2) or (..., 3) [mm] turned by ``angle`` [rad] about z (numpy; a third
    coordinate is kept). Returns a new array of the same shape."""
    P = np.asarray(P, float)
    c, s = math.cos(angle), math.sin(angle)
    out = P.copy()
    out[..., 0] = c * P[..., 0] - s * P[..., 1]
    out[..., 1] = s * P[..., 0] + c * P[..., 1]
    return out
