"""Local synthesis at a mean contact point M (docs/theory.md section 10): choose the pinion's crowning so
that at M the drive has the predesigned derivative of the gear ratio m'21, contact-ellipse major
axis 2a (for an elastic approach delta) and, where the settings allow it, the direction eta2 of
the path of contact on the gear flank.

Litvin relates the three targets to the pinion's principal curvatures at M through the relations
(I) and (II) of docs/theory.md section 10, and the curvatures to the tool settings. Here that chain is one
NLP solved by IPOPT: the unknowns are the settings (``a_c``, ``a_pl``), the contact point
``w(phi1_M)`` and its first and second derivatives along the meshing ``w'``, ``w''``, tied by
``F(w) = 0``, ``dF/dphi1 = 0`` and ``d2F/dphi1^2 = 0`` (the differentiated equations of meshing; AD
of the TCA residual, nothing hand-derived). From them: ``m'21 = phi2''``, the path tangent on the
gear ``dr2 = r2_u u2' + r2_z z2'`` and the ellipse from the pinion and gear curvature matrices
(the pinion's curvatures are thus the NLP's implicit "curvature data").
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ..compiled import nlpsol
from ..errors import ArgumentError, check_number, out_of_range
from ..gears import GearPair
from ..geometry.tools import require_rack_settings
from ..meshing.solver import ContactSettings
from ..meshing.tca import TCA, Misalignment
from .crowning import SETTINGS, SynthesisError


@dataclass(frozen=True)
class LocalTarget:
    """Targets at the mean contact point M.

    Parameters
    ----------
    mprime21 : float
        Derivative of the gear ratio ``m'21 = d^2 phi2 / d phi1^2`` at M [-] (negative: the
        predesigned parabola ``-a (phi1 - phi1M)^2`` has ``m'21 = -2a``).
    major_axis : float
        Major axis 2a of the contact ellipse at M [mm].
    eta2 : float or None
        Angle of the path of contact on the gear flank from the profile direction [rad]; None
        leaves it free (with the settings a_c, a_pl it is then a result).
    delta : float
        Elastic approach [mm].
    phi1_m : float
        Pinion angle of M [rad] (0: the pitch point).
    """

    mprime21: float
    major_axis: float
    eta2: float | None = None
    delta: float = ContactSettings.delta
    phi1_m: float = 0.0

    def __post_init__(self):
        for name in ("mprime21", "major_axis", "delta", "phi1_m") + (("eta2",) if self.eta2 is not None else ()):
            check_number(f"target.{name}", getattr(self, name))
        if not (math.isfinite(self.mprime21) and self.mprime21 < 0):
            raise out_of_range("target.mprime21", self.mprime21, "m'21 < 0 (a parabolic TE with its apex at M)")
        if not (math.isfinite(self.major_axis) and self.major_axis > 0):
            raise out_of_range("target.major_axis", self.major_axis, "2a > 0 mm")
        if self.eta2 is not None and not abs(self.eta2) < math.pi / 2:
            raise out_of_range("target.eta2", self.eta2, "|eta2| < pi/2 rad")


@dataclass(frozen=True)
class LocalDesign:
    """Result of :func:`local_synthesis`: the settings, what the NLP reached and what an independent
    TCA sweep measures at M (finite differences of solved contact points)."""

    pair: GearPair
    settings: dict
    status: str
    iterations: int
    solve_time: float
    reached: dict  # {"mprime21", "major_axis", "eta2"} in the NLP
    verified: dict  # the same measured by TCA sweeps around M

    def to_dict(self) -> dict:
        """JSON-able summary (schema in docs/results.md, "local synthesis"): ``settings`` (a_c, a_pl
        [1/mm]), IPOPT ``status`` and ``iterations``, ``solve_time_s`` [s], and ``reached`` (in the
        NLP) / ``verified`` (by an independent TCA sweep at M): ``mprime21`` [rad/rad^2],
        ``major_axis_mm`` [mm], ``eta2_deg`` [deg]."""
        def q(d):
            return {"mprime21": d["mprime21"], "major_axis_mm": d["major_axis"], "eta2_deg": math.degrees(d["eta2"])}

        return {"settings": dict(self.settings), "status": self.status, "iterations": self.iterations,
                "solve_time_s": self.solve_time, "reached": q(self.reached), "verified": q(self.verified)}


def _quantities(tca: TCA, side: str, x_scale: dict, delta: float):
    """Symbolic m'21, 2a, eta2 at M as functions of the NLP unknowns."""
    x = ca.SX.sym("x", len(SETTINGS))
    w, dw, d2w = ca.SX.sym("w", 5), ca.SX.sym("dw", 5), ca.SX.sym("d2w", 5)
    phi1 = ca.SX.sym("phi1")
    lay = tca.layout  # the TCA's parameter column by name
    mis = lay.symbols(ca.SX)["mis"]
    p1 = ca.SX(tca.pinion.p0)
    for j, name in enumerate(SETTINGS):
        p1[lay.p_index("pinion", name)] = x[j] * x_scale[name]
    p2 = ca.SX(tca.gear.p0)
    s = ca.SX.sym("s")
    Hs = tca.residual(w=w + s * dw + 0.5 * s**2 * d2w,
                      prm=lay.build({"phi1": phi1 + s, "pinion": p1, "gear": p2, "mis": mis, "z_section": 0.0}))["F"]
    H1 = ca.jacobian(Hs, s)
    H2 = ca.jacobian(H1, s)
    F0, F1, F2 = (ca.substitute(e, s, 0) for e in (Hs, H1, H2))
    prm = lay.build({"phi1": phi1, "pinion": p1, "gear": p2, "mis": mis, "z_section": 0.0})
    c = tca.contact(w=w, prm=prm)
    Ks = c["K1"] + c["K2"]  # curvature matrices of both flanks in the common basis
    lam_min = 0.5 * (Ks[0, 0] + Ks[1, 1] - ca.sqrt((Ks[0, 0] - Ks[1, 1]) ** 2 + 4 * Ks[0, 1] ** 2))
    two_a = 2 * ca.sqrt(2 * delta / lam_min)
    S2 = tca.gear.surface(side, "flank")
    r2, n2 = S2(w[2], w[3], p2)[:2]
    r2u, r2z = ca.jacobian(r2, w[2]), ca.jacobian(r2, w[3])
    t = r2u * dw[2] + r2z * dw[3]
    e_prof = r2u / ca.norm_2(r2u)
    e_face = ca.cross(n2, e_prof)
    e_face = e_face * ca.sign(e_face[2] + 1e-300)  # towards +z of the gear
    eta2 = ca.atan2(ca.dot(t, e_face), ca.dot(t, e_prof))
    eta2 = ca.if_else(eta2 > math.pi / 2, eta2 - math.pi, ca.if_else(eta2 < -math.pi / 2, eta2 + math.pi, eta2))
    mp21 = d2w[4] / tca.scale2
    return x, w, dw, d2w, phi1, mis, ca.vertcat(F0, F1, F2), mp21, two_a, eta2


def local_synthesis(pair: GearPair, target: LocalTarget, side: str = "right", verbose: bool = False,
                    mis: Misalignment | None = None, jit: bool = False) -> LocalDesign:
    """Local synthesis of the pinion crowning at M (see module docstring).

    ``jit=True`` runs the NLP's Functions as C compiled once into the disk cache
    (:func:`gearopt.compiled.nlpsol`, shared with the sweeps and the crowning NLP); the default
    interpreted solver is the cheaper choice for a single solve.

    Returns
    -------
    LocalDesign

    Raises
    ------
    SynthesisError
        No design reaches the targets (IPOPT status and the residuals are in the message).
    """
    if not isinstance(pair, GearPair):
        raise ArgumentError(f"pair = {type(pair).__name__}: expected a gearopt.gears.GearPair.",
                            param="pair", value=pair, valid="a gearopt.gears.GearPair")
    require_rack_settings(pair.pinion, "local synthesis")
    if not isinstance(target, LocalTarget):
        raise ArgumentError(f"target = {type(target).__name__}: expected a LocalTarget (target must be a LocalTarget).",
                            param="target", value=target, valid="a LocalTarget")
    if mis is not None and not isinstance(mis, Misalignment):
        raise ArgumentError(f"mis = {type(mis).__name__}: expected a Misalignment"
                            + (" (use Misalignment(**d), angles in rad)." if isinstance(mis, dict) else "."),
                            param="mis", value=mis, valid="a Misalignment")
    mis = mis or Misalignment()
    mis.check(pair, "mis")
    g1 = pair.pinion
    # the ellipse's major axis lies along the contact line, which crosses the face in b / cos(beta_b)
    b_line = min(g1.b, pair.gear.b) / math.cos(g1.beta_b)
    if target.major_axis >= b_line:
        raise out_of_range("target.major_axis", target.major_axis, f"2a < {b_line:.6g} mm, the length of the contact "
                           "line across the narrower face (b / cos beta_b): a longer ellipse leaves the tooth")
    # First guess: profile crowning from m'21 through the parabolic-rack TE law, plunging from 2a.
    tan_a = math.tan(pair.alpha_wt)
    A = -target.mprime21 / 2
    a_c0 = g1.rack.a_c or A * pair.gear.r_b / (tan_a**2 * g1.r_b**2)
    a_pl0 = g1.a_pl or 8 * target.delta / (target.major_axis**2 * math.sin(pair.alpha_wt))
    scale = {"a_c": a_c0, "a_pl": a_pl0}
    pin0 = g1.with_(rack=replace(g1.rack, a_c=a_c0), a_pl=a_pl0)
    tca = TCA(GearPair(pin0, pair.gear, pair.a), side=side)
    t0 = time.perf_counter()
    x, w, dw, d2w, phi1, mis_s, G, mp21, two_a, eta2 = _quantities(tca, side, scale, target.delta)
    w0 = tca.solve_point(target.phi1_m, mis=mis)
    prm0 = tca.prm([target.phi1_m], mis=mis)[:, 0]
    dw0 = np.asarray(tca.branch.dw(w0, prm0)).ravel()  # implicit-function first derivative
    f = ((mp21 - target.mprime21) / target.mprime21) ** 2 + ((two_a - target.major_axis) / target.major_axis) ** 2
    if target.eta2 is not None:
        f += ((eta2 - target.eta2) / 0.05) ** 2
    X = ca.vertcat(x, w, dw, d2w)
    Gs = ca.substitute(G, ca.vertcat(phi1, mis_s), ca.vertcat(target.phi1_m, mis.vector()))
    fs = ca.substitute(f, ca.vertcat(phi1, mis_s), ca.vertcat(target.phi1_m, mis.vector()))
    if not isinstance(jit, (bool, np.bool_)):
        raise out_of_range("jit", jit, "True or False (compile the NLP's Functions into the disk cache)",
                           cls=ArgumentError)
    solver = nlpsol("local_synthesis", "ipopt", {"x": X, "f": fs, "g": Gs},
                       {"ipopt.print_level": 5 if verbose else 0, "print_time": False, "ipopt.sb": "yes",
                        "ipopt.tol": 1e-12, "ipopt.max_iter": 200}, jit=bool(jit))
    x0 = np.concatenate([[1.0, 1.0], w0, dw0, np.zeros(5)])
    lbx = np.r_[[1e-4, 1e-4], [-np.inf] * 15]
    ubx = np.r_[[1e3, 1e3], [np.inf] * 15]
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=0, ubg=0)
    st = solver.stats()
    solve_time = time.perf_counter() - t0
    Xv = np.asarray(sol["x"]).ravel()
    qf = ca.Function("q", [X], [ca.substitute(ca.vertcat(mp21, two_a, eta2), ca.vertcat(phi1, mis_s),
                                              ca.vertcat(target.phi1_m, mis.vector()))])
    mp, ta, et = (float(v) for v in np.asarray(qf(Xv)).ravel())
    settings = {name: float(Xv[j] * scale[name]) for j, name in enumerate(SETTINGS)}
    ok_targets = abs(mp - target.mprime21) <= 1e-6 * abs(target.mprime21) and \
        abs(ta - target.major_axis) <= 1e-6 * target.major_axis
    if not st.get("success", False) or (target.eta2 is None and not ok_targets):
        raise SynthesisError(f"local synthesis: no design reaches the targets (IPOPT: {st.get('return_status')}); "
                             f"reached m'21 = {mp:.6g} (target {target.mprime21:.6g}), 2a = {ta:.6g} mm (target "
                             f"{target.major_axis:.6g} mm), eta2 = {math.degrees(et):.4g} deg. Settings: "
                             f"a_c = {settings['a_c']:.4g}, a_pl = {settings['a_pl']:.4g} 1/mm.")
    pin = g1.with_(rack=replace(g1.rack, a_c=settings["a_c"]), a_pl=settings["a_pl"])
    new_pair = GearPair(pin, pair.gear, pair.a)
    return LocalDesign(pair=new_pair, settings=settings, status=st.get("return_status", "?"),
                       iterations=int(st.get("iter_count", -1)), solve_time=solve_time,
                       reached={"mprime21": mp, "major_axis": ta, "eta2": et},
                       verified=verify_at_mean_point(new_pair, target, side, mis))


def verify_at_mean_point(pair: GearPair, target: LocalTarget, side: str = "right", mis: Misalignment | None = None,
                         h: float = 2e-3) -> dict:
    """Measure m'21, 2a and eta2 at M from an independent TCA sweep: central finite differences of
    the solved phi2 (step h [rad]) and of the contact points on the gear, the ellipse from the sweep."""
    tca = TCA(pair, side=side)
    phi = target.phi1_m + np.array([-2 * h, -h, 0.0, h, 2 * h])
    r = tca.sweep(phi, mis=mis, pairs=(0,), anchor=target.phi1_m, delta=target.delta)
    p2 = r.phi2[0]
    # 4th-order central second difference
    mp = (-p2[0] + 16 * p2[1] - 30 * p2[2] + 16 * p2[3] - p2[4]) / (12 * h * h)
    d = (r.r2[0, 3] - r.r2[0, 1]) / (2 * h)  # path tangent on the gear (gear frame)
    S2 = tca.gear.surface(side, "flank")
    u2, z2 = r.u2[0, 2], r.z2[0, 2]
    uu, zz = ca.SX.sym("u"), ca.SX.sym("z")
    rr, nn = S2(uu, zz, tca.gear.p0)[:2]
    ru = np.asarray(ca.Function("ru", [uu, zz], [ca.jacobian(rr, uu)])(u2, z2)).ravel()
    n2 = np.asarray(ca.Function("n", [uu, zz], [nn])(u2, z2)).ravel()
    e_prof = ru / np.linalg.norm(ru)
    e_face = np.cross(n2, e_prof)
    e_face *= np.sign(e_face[2]) or 1.0
    eta = math.atan2(d @ e_face, d @ e_prof)
    if eta > math.pi / 2:
        eta -= math.pi
    elif eta < -math.pi / 2:
        eta += math.pi
    return {"mprime21": float(mp), "major_axis": float(2 * r.ellipse_a[0, 2]), "eta2": float(eta)}
