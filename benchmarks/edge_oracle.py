"""Independent oracle for the actual TE of unmodified involute drives: patch-maximum rigid contact.

No tangency equation and no engine Function is used. Both members' finite active flanks are written
here from the textbook involute helicoid (transverse half tooth angle at radius rho:
``psi(rho) = s_t / (2 r_p) + inv(alpha_t) - inv(alpha_rho)``, turned along the face by the helix),
the pinion placed at phi1 and the gear axis fixed in space (misaligned), with the frames of
gearopt.meshing.tca's module docstring written out again here.

For a point p of the pinion's finite flank, its cylindrical coordinates (rho2, z_g, angle) about the
gear axis do not depend on the gear's rotation; if (rho2, z_g) lies on the gear's finite flank
(r_form2 <= rho2 <= r_a2, |z_g| <= b2/2), the gear flank passes through p at one gear angle
phi2(p). The gear, pushed by the pinion, rests at the largest of these angles over all such p
(any smaller one leaves p inside the gear tooth). This maximum over a 2-D patch with a curved
boundary covers every kind of contact at once: inner (surface) contact, a pinion edge on the gear
flank (p on the pinion's boundary), a gear edge on the pinion flank (the boundary of the gear's
domain), corners and edge on edge. It is found by a dense grid on the pinion flank and zooming
grids around the best candidates (converges from below; ~1e-9 rad at the default settings).

The raw TE is ``phi2 - (z1/z2) phi1`` of the pair, zero at the conjugate position of the aligned
drive (phi1 = phi2 = 0: both driving flanks through the pitch point).
"""

from __future__ import annotations

import math

import numpy as np


def _inv(a):
    return np.tan(a) - a


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


class Member:
    """Textbook geometry of one unmodified member (gearopt.gears.Gear data only)."""

    def __init__(self, g, r_w: float):
        self.z, self.b = g.z, g.b
        self.alpha_t = math.atan(math.tan(g.rack.alpha_n) / math.cos(g.beta))
        m_t = g.m_n / math.cos(g.beta)
        self.r_p = m_t * g.z / 2
        self.r_b = self.r_p * math.cos(self.alpha_t)
        self.r_a = g.r_a  # tip radius: gear data (r_p + m_n (h_aP + x) unless given otherwise)
        x_E = getattr(g, "x_E", g.x)  # the generating shift (thickness allowance included, if any)
        self.s_t = m_t * (math.pi / 2 + 2 * x_E * math.tan(g.rack.alpha_n))
        # start of the involute: end of the rack's straight flank, h below the datum line
        h = (g.rack.h_fP - g.rack.rho_fP * (1 - math.sin(g.rack.alpha_n)) - x_E) * g.m_n
        self.r_form = math.hypot(self.r_b, self.r_p * math.sin(self.alpha_t) - h / math.sin(self.alpha_t))
        self.tanb = math.tan(g.beta)
        self.helix = 0.0  # +-1: set by calibrate() (sense of the twist along z)
        self.theta = self.half_angle(r_w)

    def half_angle(self, rho):
        """Half tooth angle at transverse radius rho [rad] (mid section)."""
        a = np.arccos(np.clip(self.r_b / np.asarray(rho, float), -1.0, 1.0))
        return self.s_t / (2 * self.r_p) + _inv(self.alpha_t) - _inv(a)

    def psi(self, rho, z):
        """Polar angle of the right flank measured from the tooth's centre line (+y) towards +x."""
        return self.half_angle(rho) + self.helix * np.asarray(z) * self.tanb / self.r_p

    def point(self, rho, z, side_sign):
        p = self.psi(rho, z)
        return np.stack([side_sign * rho * np.sin(p), rho * np.cos(p), np.broadcast_to(z, np.shape(p))])


def calibrate(member: Member, tooth, side: str) -> float:
    """Sense of the helix of the written flank against the generated tooth (one point at the face
    end); returns the mismatch [rad] of the point at mid face (checks the tooth orientation)."""
    sg = 1.0 if side == "right" else -1.0
    rho = 0.5 * (member.r_form + member.r_a)
    out = []
    for z in (0.0, member.b / 2):
        u = tooth.u_at_radius(rho, z, side)
        r = np.asarray(tooth.point(side, "flank", u, z)[0], float).ravel()
        out.append(math.atan2(sg * r[0], r[1]))
    member.helix = 0.0 if member.tanb == 0 else float(np.sign((out[1] - out[0]) / member.tanb))
    return max(abs(out[0] - float(member.psi(rho, 0.0))), abs(out[1] - float(member.psi(rho, member.b / 2))))


class Oracle:
    """Patch-maximum rigid contact of an unmodified drive (see module docstring).

    Parameters
    ----------
    pair : gearopt.gears.GearPair
    side : {"right", "left"}
    mis : object with dE, crossing, intersecting, axial
    """

    def __init__(self, pair, side="right", mis=None, n=161, levels=9, keep=6):
        self.pair, self.side = pair, side
        self.sg = 1.0 if side == "right" else -1.0
        g1, g2 = pair.pinion, pair.gear
        r_w1 = pair.a_w * g1.z / (g1.z + g2.z)
        self.m1, self.m2 = Member(g1, r_w1), Member(g2, pair.a_w - r_w1)
        dE = getattr(mis, "dE", 0.0)
        self.Rmis = _ry(getattr(mis, "crossing", 0.0)) @ _rx(getattr(mis, "intersecting", 0.0))
        self.O2 = np.array([0.0, pair.a_w + dE, getattr(mis, "axial", 0.0)])
        self.n, self.levels, self.keep = n, levels, keep

    def calibrate(self, pinion_tooth, gear_tooth) -> float:
        return max(calibrate(self.m1, pinion_tooth, self.side), calibrate(self.m2, gear_tooth, self.side))

    def _phi2(self, phis, rho1, z1):
        """Gear angle at which the gear flank passes through the pinion points (rho1, z1) at the
        (pair-0) pinion angle phis; -inf where the point is not over the gear's finite flank."""
        m1, m2, sg = self.m1, self.m2, self.sg
        p = np.einsum("ij,j...->i...", _rz(sg * (m1.theta - phis)), m1.point(rho1, z1, sg))
        w = np.einsum("ji,j...->i...", self.Rmis, p - self.O2.reshape(3, *([1] * (p.ndim - 1))))
        rho2 = np.hypot(w[0], w[1])
        zg = w[2]
        ok = (rho2 >= m2.r_form) & (rho2 <= m2.r_a) & (np.abs(zg) <= m2.b / 2)
        # own-frame point (sg rho sin psi, rho cos psi) has polar angle atan2(rho cos psi, sg rho sin psi)
        psi2 = m2.psi(rho2, zg)
        v_ang = math.pi + sg * m2.theta + np.arctan2(rho2 * np.cos(psi2), sg * rho2 * np.sin(psi2))
        ang = np.arctan2(w[1], w[0]) - v_ang
        phi2 = sg * np.remainder(ang + math.pi, 2 * math.pi) - sg * math.pi
        return np.where(ok, phi2, -np.inf)

    def pair_te(self, phis):
        """Raw TE [rad] of the pair at the pair-0 pinion angle ``phis`` (-inf: no contact) and the
        contact point (rho1, z1) on the pinion."""
        m1 = self.m1
        ratio = m1.z / self.m2.z
        R = np.linspace(m1.r_form, m1.r_a, self.n)
        Z = np.linspace(-m1.b / 2, m1.b / 2, self.n)
        RR, ZZ = np.meshgrid(R, Z, indexing="ij")
        f = self._phi2(phis, RR, ZZ)
        if not np.isfinite(f).any():
            return -np.inf, (math.nan, math.nan)
        # candidates: the best grid points, at least 3 cells apart
        order = np.argsort(f, axis=None)[::-1]
        cands = []
        for idx in order:
            if not np.isfinite(f.flat[idx]) or len(cands) >= self.keep:
                break
            i, j = np.unravel_index(idx, f.shape)
            if all(abs(i - a) > 3 or abs(j - b) > 3 for a, b in cands):
                cands.append((i, j))
        # zoom around every candidate at once (one (K, 41, 41) grid a level: the same points and
        # values as candidate by candidate)
        dr, dz = R[1] - R[0], Z[1] - Z[0]
        ci, cj = np.array(cands).T
        r0, z0 = R[ci], Z[cj]
        hr, hz = np.full(ci.size, 2 * dr), np.full(ci.size, 2 * dz)
        val = f[ci, cj]
        for _ in range(self.levels):
            r = np.clip(np.linspace(r0 - hr, r0 + hr, 41, axis=1), m1.r_form, m1.r_a)
            z = np.clip(np.linspace(z0 - hz, z0 + hz, 41, axis=1), -m1.b / 2, m1.b / 2)
            rr = np.broadcast_to(r[:, :, None], (ci.size, 41, 41))
            zz = np.broadcast_to(z[:, None, :], (ci.size, 41, 41))
            g = self._phi2(phis, rr, zz).reshape(ci.size, -1)
            k = np.argmax(g, axis=1)
            gk = g[np.arange(ci.size), k]
            up = gk >= val
            val = np.where(up, gk, val)
            r0 = np.where(up, r[np.arange(ci.size), k // 41], r0)
            z0 = np.where(up, z[np.arange(ci.size), k % 41], z0)
            hr, hz = hr / 4, hz / 4
        c = int(np.argmax(val))  # the first of equal maxima, as the candidate loop kept
        best, at = val[c], (r0[c], z0[c])
        return best - ratio * phis, at

    def envelope(self, phi1, pairs=(-1, 0, 1)):
        """(N,) actual raw TE [rad] (NaN: no contact), (K, N) TE of each pair."""
        z1 = self.m1.z
        te = np.array([[self.pair_te(p - 2 * math.pi * k / z1)[0] for p in np.atleast_1d(phi1)] for k in pairs])
        env = te.max(axis=0)
        return np.where(np.isfinite(env), env, np.nan), te
