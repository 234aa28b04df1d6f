"""Independent oracle for the real tooth shape and rigid contact of spur/helical drives (used by
tests/test_flank_limit.py and benchmarks/stability.py).

Shares none of the engine's equations (no envelope / meshing equation, no tangency conditions):

* ``cut_boundary``: the transverse tooth section as what the rack-cutter leaves standing. The tool
  outline (straight or parabolic flank, tip fillet, tip land) is a dense polyline; for every radius
  r the right flank of the tooth is the smallest polar angle (clockwise from the tooth axis +y) at
  which any tool position, rolled on the pitch circle, crosses the circle r (material removal,
  minimised over the generating motion by a coarse scan and golden-section refinement).
* ``rigid_te``: for each pinion angle the gear angle at which the two finite tooth sections first
  touch without interpenetrating (bisection on a point-in-tooth penetration test of both boundary
  polylines against the other tooth), tooth pair by tooth pair; the actual TE is the largest.

The frames follow the TCA module docstring only in what defines the problem (gear centres, sense
of rotation, the pitch-point datum phi1 = phi2 = 0); TE is compared up to its constant.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.optimize import brentq


#: Flank points of the tool outline (then n/3 fillet points): the chords of a parabolic flank cut
#: ~h^2 a_c deep; 6000 points keep the section within 1e-8 rad of the exact cut.
N_OUTLINE = 6000
JUMP = N_OUTLINE // 75  # a jump of the cutting outline point (another part of the tool)


@functools.lru_cache(maxsize=32)
def tool_outline(m, alpha, h_fP, rho_fP, a_c=0.0, u_0=0.0, h_top=1.6, n=N_OUTLINE, beta=0.0):
    """Transverse outline of the rack-cutter tooth that cuts the right flank [mm]: (xi, eta) from
    ``h_top`` modules above the datum line down the flank, round the tip fillet and to the middle of
    the tip land. xi along the datum line (tooth centre at 0), eta towards the gear outside.
    Computed once per tool (the corner bisection of :func:`cut_boundary` asks again for every
    radius it tries); the array is read-only."""
    tb = (math.sin(alpha), -math.cos(alpha))
    nb = (-math.cos(alpha), -math.sin(alpha))

    def flank(u):
        d = a_c * (u - u_0) ** 2
        return np.array([math.pi * m / 4 + u * tb[0] + d * nb[0], u * tb[1] + d * nb[1]])

    def normal(u):  # unit normal pointing into the tool (away from the gear tooth)
        t = np.array([tb[0] + 2 * a_c * (u - u_0) * nb[0], tb[1] + 2 * a_c * (u - u_0) * nb[1]])
        t /= np.linalg.norm(t)
        return np.array([-t[1], t[0]])

    rho, h_f = rho_fP * m, h_fP * m
    # fillet circle: centre at distance rho from the flank (into the tool) and rho above the tip line
    uf = brentq(lambda u: (flank(u) + rho * normal(u))[1] - (-h_f + rho), -5 * m, 5 * m)
    C = flank(uf) + rho * normal(uf)
    u_top = -h_top * m / math.cos(alpha)
    us = np.linspace(u_top, uf, n)
    fl = np.array([flank(u) for u in us])
    a0 = math.atan2(*(flank(uf) - C)[::-1])
    a1 = -math.pi / 2
    if a0 > a1 + math.pi:
        a0 -= 2 * math.pi
    fi = C + rho * np.c_[np.cos(np.linspace(a0, a1, n // 3)), np.sin(np.linspace(a0, a1, n // 3))]
    land = np.c_[np.linspace(C[0], math.pi * m / 2, 20), np.full(20, -h_f)]
    P = np.vstack([fl, fi[1:], land[1:]])
    P[:, 0] /= math.cos(beta)  # the transverse section of the helical rack
    P.setflags(write=False)
    return P


def cut_boundary(z, m, alpha, h_fP, rho_fP, x=0.0, a_c=0.0, u_0=0.0, beta=0.0, depth=0.0, radii=None,
                 with_cutter=False, chunk=64, kinks=None):
    """Right-flank angle phi_R(r) [rad] of the tooth left standing by the rack-cutter, at the radii
    ``radii`` [mm] (default 1500 from just above the root to beyond the tip). ``depth`` [mm]: extra
    feed of the tool towards the centre (plunging in this section).

    Material removal: tool point (X, Y) of the rolling rack (gear turned by psi, rack shifted by
    r_p psi) is at (X - r_p psi, Y) turned clockwise by psi; it crosses the circle r where
    X - r_p psi = -+sqrt(r^2 - Y^2), at the polar angle (clockwise from +y)
    atan2(-+sqrt(r^2 - Y^2), Y) + psi. The tooth keeps what no tool point reaches: phi_R(r) is the
    smallest of these angles over the tool outline, refined by a parabola through the best three
    outline points. ``with_cutter``: also return the (fractional) index of the outline point that
    cuts each radius (the outline of :func:`tool_outline`: flank points first, then the fillet)."""
    r_p = m * z / (2 * math.cos(beta))
    P = tool_outline(m, alpha, h_fP, rho_fP, a_c, u_0, beta=beta)
    X, Y = P[:, 0], P[:, 1] + r_p + x * m - depth
    if kinks is None:
        kinks = radii is None  # default samples: add the corners of a cut-off fold exactly
    if radii is None:
        radii = np.linspace(r_p + (x - h_fP) * m - depth + 1e-3, r_p + (x + 1.5) * m, 1500)
    radii = np.asarray(radii, float)
    best = np.full(radii.size, np.inf)
    cutter = np.full(radii.size, np.nan)
    M = X.size
    for a in range(0, radii.size, chunk):
        r = radii[a:a + chunk, None]
        with np.errstate(invalid="ignore"):
            S = np.sqrt(r**2 - Y[None, :] ** 2)
        th = np.fmin(np.arctan2(-S, Y) + (X + S) / r_p, np.arctan2(S, Y) + (X - S) / r_p)
        th = np.where(np.isfinite(th), th, np.inf)
        i = np.argmin(th, axis=1)
        rows = np.arange(th.shape[0])
        v = th[rows, i]
        il, ir = np.clip(i - 1, 0, M - 1), np.clip(i + 1, 0, M - 1)
        f0, f2 = th[rows, il], th[rows, ir]
        den = f0 - 2 * v + f2
        ok = (i > 0) & (i < M - 1) & np.isfinite(den) & (den > 0)
        with np.errstate(all="ignore"):
            t = np.where(ok, 0.5 * (f0 - f2) / den, 0.0)
            vr = np.where(ok, v - 0.25 * (f0 - f2) * t, v)
        best[a:a + chunk] = np.where(np.isfinite(v), vr, np.inf)
        cutter[a:a + chunk] = np.where(np.isfinite(v), i + t, np.nan)
        # Then minimise over the continuous outline between the neighbours (golden section; points
        # that do not reach the circle, Y > r, are +inf: near the pitch line the cutting point's
        # path touches r in a cusp, and the minimum sits on that boundary).
        for row in np.flatnonzero(np.isfinite(v)):
            rr = float(radii[a + row])
            lo, hi = max(i[row] - 2.0, 0.0), min(i[row] + 2.0, M - 1.0)  # the minimum may sit between i + 1 and an unreachable i + 2
            g = (math.sqrt(5) - 1) / 2
            c, d = hi - g * (hi - lo), lo + g * (hi - lo)
            fc, fd = _theta(c, X, Y, rr, r_p), _theta(d, X, Y, rr, r_p)
            for _ in range(80):
                if fc <= fd:
                    hi, d, fd = d, c, fc
                    c = hi - g * (hi - lo)
                    fc = _theta(c, X, Y, rr, r_p)
                else:
                    lo, c, fc = c, d, fd
                    d = lo + g * (hi - lo)
                    fd = _theta(d, X, Y, rr, r_p)
            tm, fm = (c, fc) if fc <= fd else (d, fd)  # the boundary minimum may sit at Y(t) = r
            if fm < best[a + row]:
                best[a + row], cutter[a + row] = fm, tm
    if kinks:
        # A fold cut off by the tool leaves a corner in the section, where the cutting outline point
        # jumps: find its radius by bisection on the jump and add it to the samples (otherwise the
        # interpolated outline would cut the corner off).
        extra = []
        for k in np.flatnonzero(np.abs(np.diff(cutter)) > JUMP):
            lo, hi = radii[k], radii[k + 1]
            c_lo, c_hi = cutter[k], cutter[k + 1]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                c_mid = cut_boundary(z, m, alpha, h_fP, rho_fP, x, a_c, u_0, beta, depth, [mid], True, kinks=False)[2][0]
                if abs(c_mid - c_lo) < abs(c_mid - c_hi):
                    lo, c_lo = mid, c_mid
                else:
                    hi, c_hi = mid, c_mid
            extra += [lo, hi]
        if extra:
            r2, b2, c2 = cut_boundary(z, m, alpha, h_fP, rho_fP, x, a_c, u_0, beta, depth, extra, True, kinks=False)
            order = np.argsort(np.r_[radii, r2])
            radii, best, cutter = np.r_[radii, r2][order], np.r_[best, b2][order], np.r_[cutter, c2][order]
    if with_cutter:
        return radii, best, cutter
    return radii, best


def _theta(t, X, Y, r, r_p):
    """Smallest crossing angle of the circle r by the outline point at fractional index t."""
    k = min(int(t), X.size - 2)
    f = t - k
    x, y = X[k] + f * (X[k + 1] - X[k]), Y[k] + f * (Y[k + 1] - Y[k])
    if y > r:
        return math.inf
    S = math.sqrt(r * r - y * y)
    return min(math.atan2(-S, y) + (x + S) / r_p, math.atan2(S, y) + (x - S) / r_p)


class Section:
    """A tooth section as polar boundary phi_R(r) (symmetric tooth) on [r_min, r_a]."""

    def __init__(self, radii, phi_R, r_a):
        keep = np.isfinite(phi_R) & (radii <= r_a)
        self.r = np.append(radii[keep], r_a)
        self.phi = np.append(phi_R[keep], np.interp(r_a, radii[keep], phi_R[keep]))
        self.r_a = r_a

    def half_angle(self, r):
        return np.interp(r, self.r, self.phi)

    def points(self):
        """Right-flank boundary points (x, y) in the tooth frame, plus the tip land to the centre."""
        pr = np.c_[self.r * np.sin(self.phi), self.r * np.cos(self.phi)]
        tip = np.linspace(self.phi[-1], 0.0, 30)
        return np.vstack([pr, np.c_[self.r_a * np.sin(tip), self.r_a * np.cos(tip)]])

    def inside(self, x, y):
        """Points strictly inside the tooth (near its axis: within a quarter turn)."""
        r = np.hypot(x, y)
        ang = np.arctan2(x, y)
        return (r < self.r_a) & (r > self.r[0]) & (np.abs(ang) < self.half_angle(r)) & (y > 0)


def _rot(a, x, y):
    c, s = math.cos(a), math.sin(a)
    return c * x - s * y, s * x + c * y


def rigid_te(sec1: Section, sec2: Section, z1, z2, a, phi1, pairs=(-1, 0, 1), r_w1=None, window=0.03, th=None):
    """Actual TE of the rigid sections [rad] for the pinion angles ``phi1``: per pair the smallest
    gear angle without interpenetration (bisection, gear pushed by the pinion's right flank, pinion
    clockwise, gear counter-clockwise), relative to the ratio; the upper envelope over pairs.

    ``th``: the sections' angular datums (half tooth angles on the operating pitch circles; default
    from these sections).

    Returns (te_envelope (N,), te_pairs (K, N), binding radii (K, N, 2) of the touching points on
    pinion and gear)."""
    r_w1 = a * z1 / (z1 + z2) if r_w1 is None else r_w1
    r_w2 = a - r_w1
    th1, th2 = (sec1.half_angle(r_w1), sec2.half_angle(r_w2)) if th is None else th
    P1, P2 = sec1.points(), sec2.points()
    ratio = z1 / z2
    te = np.full((len(pairs), len(phi1)), -np.inf)
    bind = np.full((len(pairs), len(phi1), 2), np.nan)

    def penetrates(ph1, ph2):
        # pinion own -> fixed: CCW rotation by (-ph1 + th1); gear own -> fixed: CCW by (ph2 + pi + th2) + (0, a)
        fx, fy = _rot(-ph1 + th1, P1[:, 0], P1[:, 1])
        gx, gy = _rot(-(ph2 + math.pi + th2), fx, fy - a)
        in2 = sec2.inside(gx, gy)
        hx, hy = _rot(ph2 + math.pi + th2, P2[:, 0], P2[:, 1])
        qx, qy = _rot(-(-ph1 + th1), hx, hy + a)
        in1 = sec1.inside(qx, qy)
        return in2.any() or in1.any(), (in2, in1)

    for kk, k in enumerate(pairs):
        for i, p in enumerate(phi1):
            ph1 = p - 2 * math.pi * k / z1
            nominal = ratio * ph1
            lo, hi = nominal - window, nominal + window
            if not penetrates(ph1, lo)[0] or penetrates(ph1, hi)[0]:
                continue  # no contact of this pair within the window
            for _ in range(55):
                mid = 0.5 * (lo + hi)
                if penetrates(ph1, mid)[0]:
                    lo = mid
                else:
                    hi = mid
            te[kk, i] = hi - nominal
            _, (in2, in1) = penetrates(ph1, lo)
            r1 = np.hypot(*P1[in2].T).mean() if in2.any() else np.nan
            r2 = np.hypot(*P2[in1].T).mean() if in1.any() else np.nan
            bind[kk, i] = (r1, r2)
    env = te.max(axis=0)
    return np.where(np.isfinite(env), env, np.nan), te, bind


def rigid_te_helical(g1, g2, a, phi1, nz=9, pairs=(-1, 0, 1)):
    """Actual TE [rad] of an aligned spur or helical pair (parallel axes) with a profile- and
    longitudinally crowned pinion (``gearopt.Gear`` data used only as numbers): both bodies are
    stacks of their transverse sections, so the rigid contact is the largest over the sections z of
    the section contact. Section z of a helical member is its mid section turned by z tan(beta)/r_p
    (the pair's TE is unchanged when the pinion turns by d and the gear by (z1/z2) d, so this is a
    shift of phi1), cut with the extra depth a_pl z^2 of the plunged tool; z and -z share the cut
    (depth even in z) with opposite shifts. Max over ``2 nz - 1`` sections refined by a parabola
    through the best three."""
    m, al = g1.m_n, g1.rack.alpha_n
    r_p1 = m * g1.z / (2 * math.cos(g1.beta))
    c = math.tan(g1.beta) / r_p1
    zs = np.linspace(0.0, min(g1.b, g2.b) / 2, nz)
    sec2 = Section(*cut_boundary(g2.z, m, al, g2.rack.h_fP, g2.rack.rho_fP, x=g2.x, a_c=g2.rack.a_c,
                                 beta=g2.beta), g2.r_a)
    secs = {}
    for z in zs:
        secs[z] = Section(*cut_boundary(g1.z, m, al, g1.rack.h_fP, g1.rack.rho_fP, x=g1.x, a_c=g1.rack.a_c,
                                        u_0=g1.rack.u_0, beta=g1.beta, depth=g1.a_pl * z**2), g1.r_a)
    r_w1 = a * g1.z / (g1.z + g2.z)
    th = (secs[0.0].half_angle(r_w1), sec2.half_angle(a - r_w1))
    zz = np.r_[-zs[:0:-1], zs]
    T = np.stack([rigid_te(secs[abs(z)], sec2, g1.z, g2.z, a, np.asarray(phi1) + c * z, pairs, th=th)[0]
                  for z in zz])
    j = np.clip(np.nanargmax(np.where(np.isfinite(T), T, -np.inf), axis=0), 1, zz.size - 2)
    i = np.arange(T.shape[1])
    f0, f1, f2 = T[j - 1, i], T[j, i], T[j + 1, i]
    den = f0 - 2 * f1 + f2
    with np.errstate(all="ignore"):
        refined = np.where(np.isfinite(den) & (den < 0), f1 - (f0 - f2) ** 2 / (8 * den), f1)
    return np.fmax(refined, np.nanmax(T, axis=0))


#: Resolution of :func:`flank_end` at a tangential flank/fillet junction [mm]: there every outline
#: point near the junction cuts almost the same angle, so which one cut a radius is ill-conditioned
#: (for a straight tool it lands 0.0004-0.0008 mm below the analytic r_lim, Gear.r_lim).
JUNCTION_TOL = 0.005


def flank_end(g, r_guess, half=0.25, n=251, n_flank=N_OUTLINE):
    """Where the flank of the cut tooth section (mid section, ``gearopt.Gear`` data used as numbers)
    ends near ``r_guess`` [mm]: going down in radius, the first radius where the outline point that
    cuts it jumps (another part of the tool cuts the flank away below a fold: returns the bracket
    and True) or passes the last flank point of the outline (the fillet takes over tangentially:
    the interpolated radius twice and False)."""
    radii = np.linspace(r_guess - half, r_guess + half, n)
    r, _, cut = cut_boundary(g.z, g.m_n, g.rack.alpha_n, g.rack.h_fP, g.rack.rho_fP, x=g.x, a_c=g.rack.a_c,
                             u_0=g.rack.u_0, beta=g.beta, radii=radii, with_cutter=True)
    last = n_flank - 1
    for k in range(n - 1, 0, -1):  # from the top down
        if cut[k - 1] - cut[k] > JUMP:
            return float(r[k - 1]), float(r[k]), True
        if cut[k - 1] >= last:
            f = (last - cut[k]) / (cut[k - 1] - cut[k])
            rj = float(r[k] + f * (r[k - 1] - r[k]))
            return rj, rj, False
    raise ValueError("no end of the flank within the window")
