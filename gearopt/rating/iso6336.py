"""ISO 6336-1/-2/-3:2019 method B: the load factors, pitting and tooth-root bending of an external pair.

Every factor is a pure function of plain numbers (mm, N, rad, um as the symbol's unit says) and
:func:`rate` chains them for a pair (:class:`PairData`) at an operating point (:class:`Operation`)
into a :class:`Rating` that holds every intermediate value under its ISO symbol. The comments
cite the part, the clause and, for ISO 6336-1:2019, the equation number of the standard's text.
Units: lengths mm, forces N, stresses N/mm^2, deviations um, speeds 1/min, angles rad inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gearopt.errors import GeometryError, OptionError, out_of_range
from gearopt.rating.materials import Material

#: Y_ST, stress correction factor of the reference test gears (ISO 6336-3:2019, 3.2 and 9).
Y_ST = 2.0


def inv(alpha: float) -> float:
    """Involute function tan(alpha) - alpha [rad] (ISO 21771)."""
    return math.tan(alpha) - alpha


def inv_inverse(value: float) -> float:
    """The angle whose involute is ``value`` (Newton's method) [rad]."""
    a = (3.0 * value) ** (1.0 / 3.0) if value > 0 else 0.0
    for _ in range(60):
        f = inv(a) - value
        a -= f / math.tan(a) ** 2
        if abs(f) < 1e-15:
            break
    return a


# ---------------------------------------------------------------------------------------------------------------
# Input data
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PairData:
    """Gear data of an external cylindrical pair (ISO 21771 symbols, 1 = pinion, 2 = wheel).

    Parameters
    ----------
    z1, z2 : int
        Numbers of teeth (both > 0: internal pairs are outside this implementation).
    m_n : float
        Normal module [mm].
    alpha_n : float
        Normal pressure angle [rad].
    beta : float
        Helix angle at the reference cylinder [rad] (>= 0).
    b : float
        Common face width [mm].
    x1, x2 : float
        Profile shift coefficients.
    a : float or None
        Centre distance [mm]; None: the zero-backlash distance of x1 + x2.
    h_aP, h_fP, rho_fP : float
        Basic rack addendum, dedendum, root radius as multiples of m_n (the tool's tip is the rack's
        dedendum, ISO 6336-3:2019 Figure 2).
    s_pr : float
        Protuberance minus grinding stock of the tool [mm] (0: none).
    d_a1, d_a2 : float or None
        Tip diameters [mm]; None: d + 2 m_n (x + h_aP).
    """

    z1: int
    z2: int
    m_n: float
    alpha_n: float
    beta: float
    b: float
    x1: float = 0.0
    x2: float = 0.0
    a: float | None = None
    h_aP: float = 1.0
    h_fP: float = 1.25
    rho_fP: float = 0.38
    s_pr: float = 0.0
    d_a1: float | None = None
    d_a2: float | None = None

    def __post_init__(self) -> None:
        if self.z1 <= 0 or self.z2 <= 0:
            key = "z2" if self.z2 <= 0 else "z1"
            raise GeometryError(
                f"{key} = {getattr(self, key)!r}: ISO 6336 rating of internal gears is not implemented; valid: "
                f"z1 > 0 and z2 > 0 (an external pair).", param=key, value=getattr(self, key), valid="> 0")
        for key in ("m_n", "b"):
            if not getattr(self, key) > 0:
                raise out_of_range(key, getattr(self, key), "> 0 mm")
        if not 0 < self.alpha_n < math.pi / 4:
            raise out_of_range("alpha_n", self.alpha_n, "0 < alpha_n < pi/4 rad")
        if not 0 <= self.beta <= math.radians(45):
            raise out_of_range("beta", self.beta, "0 <= beta <= 45 deg (in rad)")


@dataclass(frozen=True)
class Accuracy:
    """Deviations of the pair that the load factors use [um] (ISO 6336-1:2019 6.5.9, 7.6, 8.3).

    Parameters
    ----------
    f_pb : float
        Transverse base pitch deviation (the larger of the pair).
    f_falpha : float
        Profile form deviation (the larger of the pair).
    f_ma : float
        Mesh misalignment from manufacturing deviations.
    f_sh : float or None
        Misalignment from shaft and pinion deformation; None: ISO 6336-1:2019 7.6 with B* = 1
        (the pinion's torque entering at one end, no offset: s = 0).
    C_a : float or None
        Tip relief [um]; None: the running-in relief C_ay (ISO 6336-1:2019 6.5.9).
    grade : int
        ISO 1328 accuracy grade (Y_DT, ISO 6336-3:2019 8.4).
    """

    f_pb: float = 10.0
    f_falpha: float = 10.0
    f_ma: float = 10.0
    f_sh: float | None = None
    C_a: float | None = None
    grade: int = 6


@dataclass(frozen=True)
class Operation:
    """Operating point and requirements.

    Parameters
    ----------
    T1 : float
        Pinion torque [N m] (> 0).
    n1 : float
        Pinion speed [1/min] (> 0 with K_v method B).
    K_A : float
        Application factor (>= 1, input; ISO 6336-1:2019 clause 5).
    L_h : float
        Required life [h] (> 0).
    nu40 : float
        Kinematic viscosity of the lubricant at 40 degC [mm^2/s].
    R_z1, R_z2 : float
        Flank roughness Rz [um].
    R_zF1, R_zF2 : float
        Root roughness Rz [um].
    S_Hmin, S_Fmin : float
        Minimum safety factors (they scale sigma_HP, sigma_FP only).
    Z_W : float
        Work hardening factor (1: both members surface-hardened or of the same hardness).
    y_lim : float
        Life factors Z_NT, Y_NT at 1e10 cycles (0.85 ... 1.0; 1.0 for optimum lubrication, material,
        manufacturing and experience; ISO 6336-2:2019 10, ISO 6336-3:2019 12).
    Y_beta_edition : str
        "2019" (default) or "2006": the form of Y_beta (:func:`helix_angle_factor_F`).
    K_v : float or None
        The dynamic factor given (method A/measured); None: method B.
    K_Hbeta, K_Halpha : float or None
        Face / transverse load factors given (e.g. from a loaded TCA); None: ISO's method B. K_Fbeta,
        K_Falpha follow from the given values by ISO's relations.
    s_R1, s_R2 : float or None
        Rim thickness [mm] (Y_B); None: solid gears.
    """

    T1: float
    n1: float
    K_A: float = 1.0
    L_h: float = 20000.0
    nu40: float = 220.0
    R_z1: float = 3.0
    R_z2: float = 3.0
    R_zF1: float = 10.0
    R_zF2: float = 10.0
    S_Hmin: float = 1.0
    S_Fmin: float = 1.0
    Z_W: float = 1.0
    y_lim: float = 0.85
    Y_beta_edition: str = "2019"
    K_v: float | None = None
    K_Hbeta: float | None = None
    K_Halpha: float | None = None
    s_R1: float | None = None
    s_R2: float | None = None

    def __post_init__(self) -> None:
        if not self.T1 > 0:
            raise out_of_range("T1", self.T1, "> 0 N m", cls=OptionError)
        if not self.L_h > 0:
            raise out_of_range("L_h", self.L_h, "> 0 h (the required life)", cls=OptionError)
        if self.n1 < 0 or (self.n1 == 0 and self.K_v is None):
            raise out_of_range("n1", self.n1, "> 0 1/min (K_v method B needs the speed; give K_v for speed 0)",
                               cls=OptionError)
        if not self.K_A >= 1:
            raise out_of_range("K_A", self.K_A, ">= 1", cls=OptionError)
        if not 0.85 <= self.y_lim <= 1.0:
            raise out_of_range("y_lim", self.y_lim, "0.85 <= y_lim <= 1.0", cls=OptionError)
        if self.Y_beta_edition not in ("2019", "2006"):
            raise OptionError(f"Y_beta_edition = {self.Y_beta_edition!r}: valid: '2019' or '2006'.",
                              param="Y_beta_edition", value=self.Y_beta_edition, valid="'2019' or '2006'")
        if not self.nu40 > 0:
            raise out_of_range("nu40", self.nu40, "> 0 mm^2/s", cls=OptionError)


# ---------------------------------------------------------------------------------------------------------------
# Geometry (ISO 21771)
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Geometry:
    """Derived geometry of the pair [mm, rad] (ISO 21771:2007)."""

    alpha_t: float
    alpha_wt: float
    beta_b: float
    a: float
    u: float
    d: tuple
    d_b: tuple
    d_a: tuple
    d_f: tuple
    d_m: tuple
    z_n: tuple
    eps_alpha: float
    eps_beta: float
    eps_gamma: float
    p_bt: float


def geometry(p: PairData) -> Geometry:
    """The pair's geometry from its gear data (ISO 21771:2007, 4 and 5).

    Raises
    ------
    GeometryError
        A transverse contact ratio outside 1 <= eps_alpha < 2.5 (ISO 6336's range for method B).
    """
    alpha_t = math.atan(math.tan(p.alpha_n) / math.cos(p.beta))
    beta_b = math.asin(math.sin(p.beta) * math.cos(p.alpha_n))
    m_t = p.m_n / math.cos(p.beta)
    d = (p.z1 * m_t, p.z2 * m_t)
    d_b = tuple(di * math.cos(alpha_t) for di in d)
    a0 = 0.5 * (d[0] + d[1])
    if p.a is None:
        alpha_wt = inv_inverse(inv(alpha_t) + 2 * math.tan(p.alpha_n) * (p.x1 + p.x2) / (p.z1 + p.z2))
        a = a0 * math.cos(alpha_t) / math.cos(alpha_wt)
    else:
        c = a0 * math.cos(alpha_t) / p.a
        if not 0 < c < 1:
            raise out_of_range("a", p.a, f"> {a0 * math.cos(alpha_t):.4g} mm (the base circles must not touch)")
        a, alpha_wt = p.a, math.acos(c)
    x = (p.x1, p.x2)
    d_a = tuple(given if given is not None else d[i] + 2 * p.m_n * (x[i] + p.h_aP)
                for i, given in enumerate((p.d_a1, p.d_a2)))
    d_f = tuple(d[i] - 2 * p.m_n * (p.h_fP - x[i]) for i in range(2))
    d_m = tuple(0.5 * (d_a[i] + d_f[i]) for i in range(2))
    z_n = tuple(z / (math.cos(beta_b) ** 2 * math.cos(p.beta)) for z in (p.z1, p.z2))
    p_bt = math.pi * m_t * math.cos(alpha_t)
    g_a = (math.sqrt(d_a[0] ** 2 - d_b[0] ** 2) + math.sqrt(d_a[1] ** 2 - d_b[1] ** 2)) / 2 - a * math.sin(alpha_wt)
    eps_alpha = g_a / p_bt                                     # ISO 21771 (transverse contact ratio)
    eps_beta = p.b * math.sin(p.beta) / (math.pi * p.m_n)       # ISO 21771 (overlap ratio)
    if not 1.0 <= eps_alpha < 2.5:
        raise out_of_range("eps_alpha", round(eps_alpha, 4), "1 <= eps_alpha < 2.5 (ISO 6336 method B)",
                           hint="Check the tip diameters, the profile shifts and the centre distance.")
    return Geometry(alpha_t, alpha_wt, beta_b, a, p.z2 / p.z1, d, d_b, d_a, d_f, d_m, z_n, eps_alpha, eps_beta,
                    eps_alpha + eps_beta, p_bt)


# ---------------------------------------------------------------------------------------------------------------
# ISO 6336-1: stiffness and load factors
# ---------------------------------------------------------------------------------------------------------------
def single_stiffness(p: PairData, g: Geometry, line_load: float) -> dict:
    """c'_th, c', c_gamma_alpha, c_gamma_beta [N/(mm um)] (ISO 6336-1:2019 clause 9, method B).

    Parameters
    ----------
    line_load : float
        F_t K_A / b [N/mm] (c' is reduced below 100 N/mm).
    """
    zn1, zn2 = g.z_n
    # 9.3.2: minimum flexibility q' of a tooth pair of solid gears [mm um/N]
    q = (0.04723 + 0.15551 / zn1 + 0.25791 / zn2 - 0.00635 * p.x1 - 0.11654 * p.x1 / zn1 - 0.00193 * p.x2
         - 0.24188 * p.x2 / zn2 + 0.00529 * p.x1 ** 2 + 0.00182 * p.x2 ** 2)
    c_th = 1.0 / q
    C_M = 0.8                      # 9.3.3: correction factor of the theoretical stiffness
    C_R = 1.0                      # 9.3.4: gear blank factor, solid gears
    # 9.3.5: basic rack factor (the same rack for both members)
    C_B = (1 + 0.5 * (1.2 - p.h_fP)) * (1 - 0.02 * (20.0 - math.degrees(p.alpha_n)))
    c_prime = c_th * C_M * C_R * C_B * math.cos(p.beta)
    if line_load < 100.0:          # 9.3.1: c' at a line load under 100 N/mm
        c_prime *= (line_load / 100.0) ** 0.25
    c_ga = c_prime * (0.75 * g.eps_alpha + 0.25)   # 9.4: mesh stiffness for K_v, K_Halpha
    return {"q_prime": q, "c_th": c_th, "C_B": C_B, "c_prime": c_prime, "c_gamma_alpha": c_ga,
            "c_gamma_beta": 0.85 * c_ga}


def _running_in(deviation: float, material: Material, v: float, k: float) -> float:
    """The running-in allowance for ``deviation`` [um]: y_alpha with ``k`` = 1 (ISO 6336-1:2019 8.3.4),
    y_beta with ``k`` = 2 (7.6.2; every constant of y_beta is twice that of y_alpha)."""
    if material.group.surface_hardened:
        return k * min(0.075 * deviation, 3.0)
    y = k * 160.0 / material.sigma_Hlim * deviation
    if 5 < v <= 10:
        y = min(y, k * 12800.0 / material.sigma_Hlim)
    elif v > 10:
        y = min(y, k * 6400.0 / material.sigma_Hlim)
    return y


def running_in_alpha(f_pb: float, material: Material, v: float) -> float:
    """Running-in allowance y_alpha for a base pitch deviation f_pb [um] (ISO 6336-1:2019 8.3.4)."""
    return _running_in(f_pb, material, v, 1.0)


def running_in_beta(F_betax: float, material: Material, v: float) -> float:
    """Running-in allowance y_beta [um] (ISO 6336-1:2019 7.6.2)."""
    return _running_in(F_betax, material, v, 2.0)


def reduced_mass(g: Geometry, density: float) -> float:
    """Reduced mass of the pair per unit face width on the line of action [kg/mm] (ISO 6336-1:2019
    6.5.9, eq. (30)), solid gears: m_i* = pi/8 rho d_mi^4 / d_bi^2, m_red = m1* m2* / (m1* + m2*)."""
    m = [math.pi / 8 * density * g.d_m[i] ** 4 / g.d_b[i] ** 2 for i in range(2)]
    return m[0] * m[1] / (m[0] + m[1])


def dynamic_factor_B(N: float, eps_gamma: float, line_load: float, c_prime: float, f_pb_eff: float,
                     f_falpha_eff: float, C_a: float) -> dict:
    """K_v by method B from the resonance ratio N (ISO 6336-1:2019 6.5).

    Parameters
    ----------
    N : float
        Resonance ratio n1 / n_E1.
    line_load : float
        F_t K_A / b [N/mm].
    c_prime : float
        Single stiffness [N/(mm um)].
    f_pb_eff, f_falpha_eff, C_a : float
        Effective base pitch and profile form deviations after running-in, tip relief [um].
    """
    # Table 8: the factors C_v1 ... C_v7 as functions of eps_gamma
    if eps_gamma <= 2.0:
        C_v2, C_v3, C_v4, C_v6 = 0.34, 0.23, 0.90, 0.47
    else:
        C_v2 = 0.57 / (eps_gamma - 0.3)
        C_v3 = 0.096 / (eps_gamma - 1.56)
        C_v4 = (0.57 - 0.05 * eps_gamma) / (eps_gamma - 1.44)
        C_v6 = 0.12 / (eps_gamma - 1.74)
    C_v1, C_v5 = 0.32, 0.47
    if eps_gamma <= 1.5:
        C_v7 = 0.75
    elif eps_gamma <= 2.5:
        C_v7 = 0.125 * math.sin(math.pi * (eps_gamma - 2.0)) + 0.875
    else:
        C_v7 = 1.0
    B_p = c_prime * f_pb_eff / line_load               # eq. (15)
    B_f = c_prime * f_falpha_eff / line_load           # eq. (16)
    B_k = abs(1.0 - c_prime * C_a / line_load)         # eq. (17)
    # eq. (11), (12): upper limit of the sub-critical range
    N_S = 0.5 + 0.35 * math.sqrt(line_load / 100.0) if line_load < 100.0 else 0.85
    K_res = C_v1 * B_p + C_v2 * B_f + C_v4 * B_k + 1.0     # eq. (20), main resonance range
    K_sup = C_v5 * B_p + C_v6 * B_f + C_v7                 # eq. (21), super-critical range
    if N <= N_S:
        K = C_v1 * B_p + C_v2 * B_f + C_v3 * B_k           # eq. (13)
        K_v, rng = N * K + 1.0, "subcritical"              # eq. (14)
    elif N <= 1.15:
        K_v, rng = K_res, "main resonance"
    elif N < 1.5:
        K_v, rng = K_sup + (K_res - K_sup) * (1.5 - N) / 0.35, "intermediate"   # eq. (22)
    else:
        K_v, rng = K_sup, "supercritical"
    return {"K_v": K_v, "N_S": N_S, "B_p": B_p, "B_f": B_f, "B_k": B_k, "K_v_range": rng}


def face_load_factor_H(F_m_per_b: float, f_sh: float, f_ma: float, c_gamma_beta: float, material: Material,
                       v: float) -> dict:
    """K_Hbeta from the equivalent misalignment (ISO 6336-1:2019 7.6, no helix modification: B1 = B2 = 1).

    Parameters
    ----------
    F_m_per_b : float
        Mean transverse line load F_t K_A K_v / b [N/mm].
    f_sh, f_ma : float
        Misalignment from deformations and from manufacturing [um].
    """
    F_betax = max(1.33 * f_sh + f_ma, 0.005 * F_m_per_b)     # initial equivalent misalignment, >= F_betax,min
    y_beta = running_in_beta(F_betax, material, v)
    F_betay = F_betax - y_beta                                # effective equivalent misalignment
    r = F_betay * c_gamma_beta / (2.0 * F_m_per_b)
    K = 1.0 + r if r <= 1.0 else 2.0 * math.sqrt(r)          # linear load distribution, contact over b or not
    return {"F_betax": F_betax, "y_beta": y_beta, "F_betay": F_betay, "K_Hbeta": K}


def face_load_factor_F(K_Hbeta: float, b: float, h: float) -> float:
    """K_Fbeta = K_Hbeta^N_F (ISO 6336-1:2019 7.7), b/h the smaller of the pair's, not below 3."""
    bh = max(b / h, 3.0)
    N_F = bh ** 2 / (1.0 + bh + bh ** 2)
    return K_Hbeta ** N_F


def transverse_load_factors(eps_alpha: float, eps_gamma: float, Z_eps: float, c_gamma_alpha: float,
                            f_pb: float, y_alpha: float, F_tH_per_b: float) -> tuple[float, float]:
    """K_Halpha, K_Falpha (ISO 6336-1:2019 8.3, method B, eq. (73)-(76)).

    Parameters
    ----------
    F_tH_per_b : float
        F_t K_A K_v K_Hbeta / b [N/mm].
    """
    t = c_gamma_alpha * (f_pb - y_alpha) / F_tH_per_b
    if eps_gamma <= 2.0:
        K = eps_gamma / 2.0 * (0.9 + 0.4 * t)                                          # eq. (73)
    else:
        K = 0.9 + 0.4 * math.sqrt(2.0 * (eps_gamma - 1.0) / eps_gamma) * t            # eq. (74)
    K_H = min(max(K, 1.0), eps_gamma / (eps_alpha * Z_eps ** 2))                       # eq. (75)
    K_F = min(max(K, 1.0), eps_gamma / (0.25 * eps_alpha + 0.75))                      # eq. (76)
    return K_H, K_F


# ---------------------------------------------------------------------------------------------------------------
# ISO 6336-2: pitting factors
# ---------------------------------------------------------------------------------------------------------------
def zone_factor(alpha_t: float, alpha_wt: float, beta_b: float) -> float:
    """Z_H (ISO 6336-2:2019, clause 6): sqrt(2 cos beta_b cos alpha_wt / (cos^2 alpha_t sin alpha_wt))."""
    return math.sqrt(2 * math.cos(beta_b) * math.cos(alpha_wt) / (math.cos(alpha_t) ** 2 * math.sin(alpha_wt)))


def elasticity_factor(E1: float, nu1: float, E2: float, nu2: float) -> float:
    """Z_E [sqrt(N/mm^2)] (ISO 6336-2:2019, clause 7)."""
    return math.sqrt(1.0 / (math.pi * ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2)))


def contact_ratio_factor(eps_alpha: float, eps_beta: float) -> float:
    """Z_epsilon (ISO 6336-2:2019, clause 8)."""
    if eps_beta >= 1.0:
        return math.sqrt(1.0 / eps_alpha)
    return math.sqrt((4.0 - eps_alpha) / 3.0 * (1.0 - eps_beta) + eps_beta / eps_alpha)


def helix_angle_factor_H(beta: float) -> float:
    """Z_beta = 1 / sqrt(cos beta) (ISO 6336-2:2019, clause 9)."""
    return 1.0 / math.sqrt(math.cos(beta))


def single_pair_factors(p: PairData, g: Geometry) -> tuple[float, float]:
    """Z_B, Z_D: contact stress at the inner points of single pair contact from the pitch point's
    (ISO 6336-2:2019, clause 6.2: M_1, M_2 and the interpolation with eps_beta)."""
    ra = [math.sqrt((g.d_a[i] / g.d_b[i]) ** 2 - 1.0) for i in range(2)]
    z = (p.z1, p.z2)
    e = g.eps_alpha - 1.0
    M1 = math.tan(g.alpha_wt) / math.sqrt((ra[0] - 2 * math.pi / z[0]) * (ra[1] - e * 2 * math.pi / z[1]))
    M2 = math.tan(g.alpha_wt) / math.sqrt((ra[1] - 2 * math.pi / z[1]) * (ra[0] - e * 2 * math.pi / z[0]))
    out = []
    for M in (M1, M2):
        if g.eps_beta >= 1.0:
            out.append(1.0)
        else:
            out.append(max(1.0, M - g.eps_beta * (M - 1.0)))
    return out[0], out[1]


def log_interp(N: float, points: tuple) -> float:
    """A life factor from its corner points ((N_i, factor_i), ...) interpolated linearly in log-log
    (the S-N lines of ISO 6336-2:2019 Table 2 and ISO 6336-3:2019 Table 3), constant outside."""
    if N <= points[0][0]:
        return points[0][1]
    for (n0, y0), (n1, y1) in zip(points[:-1], points[1:]):
        if N <= n1:
            t = math.log(N / n0) / math.log(n1 / n0)
            return math.exp(math.log(y0) + t * (math.log(y1) - math.log(y0)))
    return points[-1][1]


def life_points_H(material: Material, y_lim: float = 0.85) -> tuple:
    """Corner points (N, Z_NT) of the pitting S-N line (ISO 6336-2:2019, clause 10, Table 2; no pitting
    permitted): static, reference (Z_NT = 1) and 1e10 cycles (``y_lim``)."""
    if material.group.key == "NT":
        return ((1e5, 1.3), (2e6, 1.0), (1e10, y_lim))
    return ((1e5, 1.6), (5e7, 1.0), (1e10, y_lim))


def life_factor_H(N_L: float, material: Material, y_lim: float = 0.85) -> float:
    """Z_NT (ISO 6336-2:2019, clause 10, Table 2; no pitting permitted)."""
    return log_interp(N_L, life_points_H(material, y_lim))


def lubricant_factors(sigma_Hlim: float, nu40: float, v: float, R_z10: float) -> dict:
    """Z_L, Z_v, Z_R (ISO 6336-2:2019, clause 11, method B). ``sigma_Hlim`` the smaller of the pair's."""
    if sigma_Hlim < 850.0:
        C_ZL = 0.83
    elif sigma_Hlim < 1200.0:
        C_ZL = sigma_Hlim / 4375.0 + 0.6357
    else:
        C_ZL = 0.91
    Z_L = C_ZL + 4.0 * (1.0 - C_ZL) / (1.2 + 134.0 / nu40) ** 2
    C_Zv = C_ZL + 0.02
    Z_v = C_Zv + 2.0 * (1.0 - C_Zv) / math.sqrt(0.8 + 32.0 / v)
    if sigma_Hlim < 850.0:
        C_ZR = 0.15
    elif sigma_Hlim < 1200.0:
        C_ZR = 0.32 - 0.0002 * sigma_Hlim
    else:
        C_ZR = 0.08
    Z_R = (3.0 / R_z10) ** C_ZR
    return {"C_ZL": C_ZL, "Z_L": Z_L, "Z_v": Z_v, "C_ZR": C_ZR, "Z_R": Z_R}


def size_factor_H(m_n: float, material: Material) -> float:
    """Z_X = 1 (ISO 6336-2:2019, clause 13: 1 unless the size effect is established by experience)."""
    return 1.0


# ---------------------------------------------------------------------------------------------------------------
# ISO 6336-3: bending factors
# ---------------------------------------------------------------------------------------------------------------
def tooth_form(i: int, p: PairData, g: Geometry) -> dict:
    """Y_F, Y_S and their geometry by method B: the 30-degree tangent of the generated fillet and the
    load at the outer point of single pair contact of the virtual spur gear (ISO 6336-3:2019, 6.2 and 7).

    ``i`` is the member (0 pinion, 1 wheel). The fillet is the trochoid cut by the tool tip radius
    rho_fP of the rack with dedendum h_fP (multiples of m_n) and protuberance s_pr [mm]. Returns s_Fn, h_Fe, rho_F [mm], alpha_Fen,
    theta [rad], Y_F, Y_S, q_s.
    """
    z, x, beta = (p.z1, p.x1, p.beta) if i == 0 else (p.z2, p.x2, p.beta)
    m = p.m_n
    an = p.alpha_n
    h_fP, rho_fP = p.h_fP * m, p.rho_fP * m
    z_n = z / (math.cos(g.beta_b) ** 2 * math.cos(beta))
    E = math.pi / 4 * m - h_fP * math.tan(an) + p.s_pr / math.cos(an) - (1 - math.sin(an)) * rho_fP / math.cos(an)
    G = rho_fP / m - h_fP / m + x
    H = 2.0 / z_n * (math.pi / 2 - E / m) - math.pi / 3
    theta = math.pi / 6
    for _ in range(100):                                # theta = 2 G / z_n tan(theta) - H, fixed point
        new = 2 * G / z_n * math.tan(theta) - H
        if abs(new - theta) < 1e-13:
            theta = new
            break
        theta = new
    s_Fn = m * (z_n * math.sin(math.pi / 3 - theta) + math.sqrt(3) * (G / math.cos(theta) - rho_fP / m))
    rho_F = m * (rho_fP / m + 2 * G ** 2 / (math.cos(theta) * (z_n * math.cos(theta) ** 2 - 2 * G)))
    # the virtual spur gear and its outer point of single pair contact
    d = g.d[i]
    d_n = d / math.cos(g.beta_b) ** 2
    d_bn = d_n * math.cos(an)
    d_an = d_n + g.d_a[i] - d
    eps_an = g.eps_alpha / math.cos(g.beta_b) ** 2
    d_en = 2 * math.sqrt((math.sqrt((d_an / 2) ** 2 - (d_bn / 2) ** 2)
                          - math.pi * d * math.cos(beta) * math.cos(an) / z * (eps_an - 1)) ** 2 + (d_bn / 2) ** 2)
    alpha_en = math.acos(d_bn / d_en)
    gamma_e = (0.5 * math.pi + 2 * x * math.tan(an)) / z_n + inv(an) - inv(alpha_en)
    alpha_Fen = alpha_en - gamma_e
    h_Fe = 0.5 * m * ((math.cos(gamma_e) - math.sin(gamma_e) * math.tan(alpha_Fen)) * d_en / m
                      - z_n * math.cos(math.pi / 3 - theta) - G / math.cos(theta) + rho_fP / m)
    return {"z_n": z_n, "theta": theta, "d_en": d_en,
            **form_factors(s_Fn, h_Fe, rho_F, alpha_Fen, m, an)}


def form_factors(s_Fn: float, h_Fe: float, rho_F: float, alpha_Fen: float, m_n: float, alpha_n: float) -> dict:
    """Y_F and Y_S from the critical section (ISO 6336-3:2019, 6.2 and 7.2).

    Parameters
    ----------
    s_Fn, h_Fe, rho_F : float
        Chord at the 30-degree tangent points, bending moment arm, fillet radius there [mm].
    alpha_Fen : float
        Load direction angle at the outer point of single contact [rad].
    m_n, alpha_n : float
        Normal module [mm], normal pressure angle [rad].
    """
    Y_F = 6 * (h_Fe / m_n) * math.cos(alpha_Fen) / ((s_Fn / m_n) ** 2 * math.cos(alpha_n))
    L = s_Fn / h_Fe
    q_s = s_Fn / (2 * rho_F)
    Y_S = (1.2 + 0.13 * L) * q_s ** (1.0 / (1.21 + 2.3 / L))
    return {"s_Fn": s_Fn, "rho_F": rho_F, "alpha_Fen": alpha_Fen, "h_Fe": h_Fe, "Y_F": Y_F, "Y_S": Y_S, "q_s": q_s}


def helix_angle_factor_F(eps_beta: float, beta: float, edition: str = "2019") -> float:
    """Y_beta: 1 - eps_beta beta/120 deg with eps_beta <= 1 and beta <= 30 deg (ISO 6336-3:2006 and
    the bracket of 2019); ``edition="2019"`` divides it by cos^3 beta (ISO 6336-3:2019, clause 8.3,
    as read here; not validated against a published example, docs/rating.md)."""
    bdeg = min(math.degrees(beta), 30.0)
    y0 = 1.0 - min(eps_beta, 1.0) * bdeg / 120.0
    return y0 / math.cos(beta) ** 3 if edition == "2019" else y0


def rim_factor(s_R: float | None, h_t: float, name: str = "s_R") -> float:
    """Y_B (ISO 6336-3:2019, 8.4 external gears): 1 for s_R/h_t >= 1.2 (and solid gears, s_R None)."""
    if s_R is None:
        return 1.0
    r = s_R / h_t
    if r >= 1.2:
        return 1.0
    if r <= 0.5:
        raise out_of_range(name, s_R, f"s_R / h_t > 0.5 (s_R > {0.5 * h_t:.3g} mm)")
    return 1.6 * math.log(2.242 / r)


def deep_tooth_factor(eps_alpha: float, beta_b: float, grade: int) -> float:
    """Y_DT (ISO 6336-3:2019, 8.5) from the virtual contact ratio eps_alphan = eps_alpha / cos^2 beta_b."""
    e = eps_alpha / math.cos(beta_b) ** 2
    if e <= 2.05 or grade > 4:
        return 1.0
    return 0.7 if e > 2.5 else -0.666 * e + 2.366


def life_points_F(material: Material, y_lim: float = 0.85) -> tuple:
    """Corner points (N, Y_NT) of the bending S-N line (ISO 6336-3:2019, clause 12, Table 3)."""
    k = material.group.key
    if k == "V":
        return ((1e4, 2.5), (3e6, 1.0), (1e10, y_lim))
    if k == "NT":
        return ((1e3, 1.6), (3e6, 1.0), (1e10, y_lim))
    return ((1e3, 2.5), (3e6, 1.0), (1e10, y_lim))


def life_factor_F(N_L: float, material: Material, y_lim: float = 0.85) -> float:
    """Y_NT (ISO 6336-3:2019, clause 12, Table 3)."""
    return log_interp(N_L, life_points_F(material, y_lim))


def notch_sensitivity(q_s: float, material: Material) -> float:
    """Y_deltarelT (ISO 6336-3:2019, 13.3 method B): relative stress gradients chi* = (1 + 2 q_s)/5,
    chi*_T for q_sT = 2.5, slip-layer thickness rho' of the material (Table 4)."""
    rho = material.group.slip_layer
    chi = (1 + 2 * q_s) / 5.0
    chi_T = (1 + 2 * 2.5) / 5.0
    return (1 + math.sqrt(rho * chi)) / (1 + math.sqrt(rho * chi_T))


def surface_factor(R_z: float, material: Material) -> float:
    """Y_RrelT (ISO 6336-3:2019, 14.3 method B) from the root roughness Rz [um] (1 <= Rz <= 40)."""
    nt = material.group.key == "NT"
    if R_z < 1.0:
        return 1.025 if nt else 1.120
    if nt:
        return 4.299 - 3.259 * (R_z + 1.0) ** 0.0058
    return 1.674 - 0.529 * (R_z + 1.0) ** 0.1


def size_factor_F(m_n: float, material: Material) -> float:
    """Y_X (ISO 6336-3:2019, clause 15, Table 5)."""
    if material.group.key in ("Eh", "NT"):
        return 1.0 if m_n <= 5 else (0.8 if m_n >= 25 else 1.05 - 0.01 * m_n)
    return 1.0 if m_n <= 5 else (0.85 if m_n >= 30 else 1.03 - 0.006 * m_n)


# ---------------------------------------------------------------------------------------------------------------
# The rating
# ---------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Rating:
    """Every value of one rating, by ISO symbol.

    ``values[sym]`` is a float for a pair value and a (pinion, wheel) tuple for a member value;
    ``units[sym]`` its unit; ``sources`` says where K_v, K_Hbeta, K_Halpha came from.
    """

    values: dict
    units: dict
    sources: dict = field(default_factory=dict)

    def __getitem__(self, key: str):
        return self.values[key]

    def table(self) -> list[tuple[str, str, str, str]]:
        """Rows (symbol, unit, pinion/pair value, wheel value) for a CSV."""
        rows = []
        for k, v in self.values.items():
            if isinstance(v, tuple):
                rows.append((k, self.units.get(k, "-"), repr(v[0]), repr(v[1])))
            elif isinstance(v, str):
                rows.append((k, "-", v, ""))
            else:
                rows.append((k, self.units.get(k, "-"), repr(v), ""))
        return rows


UNITS = {"F_t": "N", "v": "m/s", "d": "mm", "d_b": "mm", "d_a": "mm", "d_f": "mm", "d_m": "mm", "a": "mm",
         "alpha_t": "rad", "alpha_wt": "rad", "beta_b": "rad", "c_th": "N/(mm um)", "c_prime": "N/(mm um)",
         "c_gamma_alpha": "N/(mm um)", "c_gamma_beta": "N/(mm um)", "m_red": "kg/mm", "n_E1": "1/min",
         "f_sh": "um", "f_ma": "um", "F_betax": "um", "F_betay": "um", "y_beta": "um", "y_alpha": "um",
         "C_a": "um", "sigma_H0": "N/mm^2", "sigma_H": "N/mm^2", "sigma_HP": "N/mm^2", "sigma_Hlim": "N/mm^2",
         "sigma_F0": "N/mm^2", "sigma_F": "N/mm^2", "sigma_FP": "N/mm^2", "sigma_Flim": "N/mm^2",
         "Z_E": "sqrt(N/mm^2)", "s_Fn": "mm", "h_Fe": "mm", "rho_F": "mm", "alpha_Fen": "rad", "R_z10": "um",
         "N_L": "cycles", "line_load": "N/mm", "rho_red": "mm"}


def rate(p: PairData, op: Operation, mat1: Material, mat2: Material, acc: Accuracy | None = None,
         tooth_forms: tuple | None = None) -> Rating:
    """Pitting and bending safety factors of both members by ISO 6336-1/-2/-3:2019 method B.

    Parameters
    ----------
    p : PairData
    op : Operation
    mat1, mat2 : Material
        Pinion's and wheel's materials (:func:`gearopt.rating.materials.material`).
    acc : Accuracy or None
        Deviations; None: ``Accuracy()``.
    tooth_forms : (dict, dict) or None
        The critical sections of pinion and wheel measured on their generated teeth (``s_Fn``,
        ``h_Fe``, ``rho_F`` [mm], ``alpha_Fen`` [rad]; :func:`gearopt.rating.pair.generated_tooth_forms`)
        in place of ISO's closed forms; None: the closed forms.

    Returns
    -------
    Rating
    """
    acc = Accuracy() if acc is None else acc
    g = geometry(p)
    V: dict = {}
    src = {"K_v": "given" if op.K_v is not None else "ISO 6336-1 method B",
           "K_Hbeta": "given" if op.K_Hbeta is not None else "ISO 6336-1 method B",
           "K_Halpha": "given" if op.K_Halpha is not None else "ISO 6336-1 method B"}
    V.update(a=g.a, alpha_t=g.alpha_t, alpha_wt=g.alpha_wt, beta_b=g.beta_b, u=g.u, d=g.d, d_b=g.d_b, d_a=g.d_a,
             d_f=g.d_f, d_m=g.d_m, z_n=g.z_n, eps_alpha=g.eps_alpha, eps_beta=g.eps_beta, eps_gamma=g.eps_gamma)
    F_t = 2000.0 * op.T1 / g.d[0]                       # ISO 6336-1:2019 clause 5: nominal tangential load [N]
    v = math.pi * g.d[0] * op.n1 / 60000.0               # pitch line velocity [m/s]
    line = F_t * op.K_A / p.b
    V.update(F_t=F_t, v=v, K_A=op.K_A, line_load=line)
    st = single_stiffness(p, g, line)
    V.update(st)
    # --- K_v (ISO 6336-1:2019 clause 6, method B)
    y_alpha = 0.5 * (running_in_alpha(acc.f_pb, mat1, v) + running_in_alpha(acc.f_pb, mat2, v))
    y_f = 0.5 * (running_in_alpha(acc.f_falpha, mat1, v) + running_in_alpha(acc.f_falpha, mat2, v))
    sig_min = min(mat1.sigma_Hlim, mat2.sigma_Hlim)
    C_a = acc.C_a if acc.C_a is not None else (1 / 18.0) * (sig_min / 97.0 - 18.45) ** 2 + 1.5   # 6.5.9, C_ay
    m_red = reduced_mass(g, 0.5 * (mat1.group.density + mat2.group.density))
    n_E1 = 30000.0 / (math.pi * p.z1) * math.sqrt(st["c_gamma_alpha"] / m_red)     # eq. (6)
    N = op.n1 / n_E1                                                                # eq. (9)
    V.update(y_alpha=y_alpha, C_a=C_a, m_red=m_red, n_E1=n_E1, N=N)
    if op.K_v is None:
        kv = dynamic_factor_B(N, g.eps_gamma, line, st["c_prime"], acc.f_pb - y_alpha, acc.f_falpha - y_f, C_a)
        V.update(kv)
        K_v = kv["K_v"]
    else:
        K_v = float(op.K_v)
        V["K_v"] = K_v
    # --- K_Hbeta, K_Fbeta (clause 7)
    F_m_b = F_t * op.K_A * K_v / p.b
    f_sh = acc.f_sh if acc.f_sh is not None else F_m_b * 0.023 * (abs(1.0 - 0.3) + 0.3) * (p.b / g.d[0]) ** 2
    mat_soft = mat1 if mat1.sigma_Hlim <= mat2.sigma_Hlim else mat2
    kh = face_load_factor_H(F_m_b, f_sh, acc.f_ma, st["c_gamma_beta"], mat_soft, v)
    V.update(f_sh=f_sh, f_ma=acc.f_ma, F_betax=kh["F_betax"], y_beta=kh["y_beta"], F_betay=kh["F_betay"])
    V["K_Hbeta_ISO"] = kh["K_Hbeta"]
    K_Hbeta = kh["K_Hbeta"] if op.K_Hbeta is None else float(op.K_Hbeta)
    h = min((g.d_a[i] - g.d_f[i]) / 2 for i in range(2))
    K_Fbeta = face_load_factor_F(K_Hbeta, p.b, h)
    V.update(K_Hbeta=K_Hbeta, K_Fbeta=K_Fbeta)
    # --- pitting factors needed for K_Halpha's limit
    Z_eps = contact_ratio_factor(g.eps_alpha, g.eps_beta)
    # --- K_Halpha, K_Falpha (clause 8)
    K_Ha, K_Fa = transverse_load_factors(g.eps_alpha, g.eps_gamma, Z_eps, st["c_gamma_alpha"], acc.f_pb, y_alpha,
                                         F_t * op.K_A * K_v * K_Hbeta / p.b)
    V["K_Halpha_ISO"] = K_Ha
    if op.K_Halpha is not None:
        K_Ha = float(op.K_Halpha)
        K_Fa = K_Ha   # ISO 6336-1:2019 8.3.2: the same value for root stress from a measured/computed sharing
    V.update(K_Halpha=K_Ha, K_Falpha=K_Fa)
    # --- ISO 6336-2: pitting
    Z_H = zone_factor(g.alpha_t, g.alpha_wt, g.beta_b)
    Z_E = elasticity_factor(mat1.E, mat1.nu, mat2.E, mat2.nu)
    Z_beta = helix_angle_factor_H(p.beta)
    Z_B, Z_D = single_pair_factors(p, g)
    sigma_H0 = Z_H * Z_E * Z_eps * Z_beta * math.sqrt(F_t / (g.d[0] * p.b) * (g.u + 1) / g.u)   # 6336-2 cl. 5
    K = op.K_A * K_v * K_Hbeta * K_Ha
    sigma_H = (Z_B * sigma_H0 * math.sqrt(K), Z_D * sigma_H0 * math.sqrt(K))
    N_L = (60.0 * op.n1 * op.L_h, 60.0 * op.n1 * op.L_h / g.u)
    Z_NT = (life_factor_H(N_L[0], mat1, op.y_lim), life_factor_H(N_L[1], mat2, op.y_lim))
    rho = [0.5 * g.d_b[i] * math.tan(g.alpha_wt) for i in range(2)]
    rho_red = rho[0] * rho[1] / (rho[0] + rho[1])
    R_z10 = 0.5 * (op.R_z1 + op.R_z2) * (10.0 / rho_red) ** (1.0 / 3.0)      # 6336-2 cl. 11, mean roughness
    lub = lubricant_factors(sig_min, op.nu40, v, R_z10) if v > 0 else {
        **lubricant_factors(sig_min, op.nu40, 1.0, R_z10), "Z_v": 1.0}
    Z_X = (size_factor_H(p.m_n, mat1), size_factor_H(p.m_n, mat2))
    sig_lim = (mat1.sigma_Hlim, mat2.sigma_Hlim)
    common = lub["Z_L"] * lub["Z_v"] * lub["Z_R"] * op.Z_W
    sigma_HP = tuple(sig_lim[i] * Z_NT[i] * common * Z_X[i] / op.S_Hmin for i in range(2))
    S_H = tuple(sigma_HP[i] * op.S_Hmin / sigma_H[i] for i in range(2))
    V.update(Z_H=Z_H, Z_E=Z_E, Z_eps=Z_eps, Z_beta=Z_beta, Z_B=Z_B, Z_D=Z_D, sigma_H0=sigma_H0, sigma_H=sigma_H,
             N_L=N_L, Z_NT=Z_NT, rho_red=rho_red, R_z10=R_z10, C_ZL=lub["C_ZL"], Z_L=lub["Z_L"], Z_v=lub["Z_v"],
             C_ZR=lub["C_ZR"], Z_R=lub["Z_R"], Z_W=op.Z_W, Z_X=Z_X, sigma_Hlim=sig_lim, sigma_HP=sigma_HP, S_H=S_H)
    # --- ISO 6336-3: bending
    tf = (tooth_form(0, p, g), tooth_form(1, p, g))
    src["Y_F"] = "ISO 6336-3 method B closed form"
    if tooth_forms is not None:
        tf = tuple({**tf[i], **form_factors(tooth_forms[i]["s_Fn"], tooth_forms[i]["h_Fe"], tooth_forms[i]["rho_F"],
                                            tooth_forms[i]["alpha_Fen"], p.m_n, p.alpha_n)} for i in range(2))
        src["Y_F"] = "generated tooth"
    Y_beta = helix_angle_factor_F(g.eps_beta, p.beta, op.Y_beta_edition)
    h_t = tuple((g.d_a[i] - g.d_f[i]) / 2 for i in range(2))
    Y_B = (rim_factor(op.s_R1, h_t[0], "s_R1"), rim_factor(op.s_R2, h_t[1], "s_R2"))
    Y_DT = deep_tooth_factor(g.eps_alpha, g.beta_b, acc.grade)
    mats = (mat1, mat2)
    sigma_F0 = tuple(F_t / (p.b * p.m_n) * tf[i]["Y_F"] * tf[i]["Y_S"] * Y_beta * Y_B[i] * Y_DT for i in range(2))
    KF = op.K_A * K_v * K_Fbeta * K_Fa
    sigma_F = tuple(s * KF for s in sigma_F0)
    Y_NT = tuple(life_factor_F(N_L[i], mats[i], op.y_lim) for i in range(2))
    Y_d = tuple(notch_sensitivity(tf[i]["q_s"], mats[i]) for i in range(2))
    Y_R = (surface_factor(op.R_zF1, mat1), surface_factor(op.R_zF2, mat2))
    Y_X = tuple(size_factor_F(p.m_n, m) for m in mats)
    sig_Flim = (mat1.sigma_Flim, mat2.sigma_Flim)
    sigma_FP = tuple(sig_Flim[i] * Y_ST * Y_NT[i] * Y_d[i] * Y_R[i] * Y_X[i] / op.S_Fmin for i in range(2))
    S_F = tuple(sigma_FP[i] * op.S_Fmin / sigma_F[i] for i in range(2))
    for k in ("theta", "s_Fn", "rho_F", "h_Fe", "alpha_Fen", "q_s", "Y_F", "Y_S"):
        V[k] = (tf[0][k], tf[1][k])
    V.update(Y_beta=Y_beta, Y_B=Y_B, Y_DT=Y_DT, sigma_F0=sigma_F0, sigma_F=sigma_F, Y_ST=Y_ST, Y_NT=Y_NT,
             Y_deltarelT=Y_d, Y_RrelT=Y_R, Y_X=Y_X, sigma_Flim=sig_Flim, sigma_FP=sigma_FP, S_F=S_F)
    return Rating(V, dict(UNITS), src)

