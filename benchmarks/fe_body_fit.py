"""The gear body of loaded TCA's default compliance: plane-stress FE full gears held at their bores, and the
fit of Sainsot's functional form to them (docs/ltca.md sections 2 and 7).

    python benchmarks/fe_body_fit.py             # generate what is missing (CalculiX, incremental, resumable),
                                                 # then fit and report the fit and the hold-out error
    python benchmarks/fe_body_fit.py --fit       # fit only, from benchmarks/data/fe_body_fit.json (no CalculiX)
    python benchmarks/fe_body_fit.py --generate  # generate only
    python benchmarks/fe_body_fit.py --generate-neighbours  # the neighbouring teeth's responses of every recorded
                                                 # gear (CalculiX, the full gears again with the teeth d = +-1, +-2,
                                                 # +-z/4, -z/2 read; resumable), then the fit of (N1), recorded
    python benchmarks/fe_body_fit.py --neighbours [--record]  # the fit of the neighbour term (N1) of
                                                 # gearopt.ltca.neighbours from the recorded responses (no CalculiX)

Each case is a spur gear (m_n 3 mm, ISO 53 profile A, tooth count ``z``, profile shift ``x``) 2 mm wide (plane
stress, as Sainsot et al.'s term is written with ``E``; on the 20/40 pinion of docs/ltca.md section 7 the full
gear's body is the same 2 and 20 mm wide), held at its bore ``r_int = r_f / h_fi``. Its body per unit face width
at a flank row is the full gear's compliance (:func:`gearopt.fea.influence.line_load_compliance`, ``teeth = z``,
``support = "bore"``; a normal line load uniform over the face, the response on the tooth's middle line along
the row's normal) minus the tooth's (the same mesh, 3 teeth, held 0.3 m_n below the root circle), at three
loaded rows (the second lowest, the middle and the highest of the 9 flank rows), E 210 GPa, nu 0.3. The mesh
is the line-load mesh of benchmarks/fe_full_gear_body.py (n_half 6, n_flank 8, n_fillet 5, n_rim 8) with 2
face layers; on the 20/40 pinion it converges about 5 % higher on finer meshes (docs/ltca.md section 7).

Results go to ``benchmarks/data/fe_body_fit.json`` after every case (a re-run skips the recorded cases). The
fit: the 24 coefficients of ``L*, M*, P*, Q* = A / theta_f^2 + B h_fi^2 + C h_fi / theta_f + D / theta_f +
E h_fi + F`` in ``c_f = cos^2(g) / E (L* (u_f / S_f)^2 + M* (u_f / S_f) + P* (1 + Q* tan^2 g))`` (Sainsot,
Velex & Duverger 2004), by Gauss-Newton on the relative error of the fitting cases, with a weak pull towards
Sainsot's coefficients (the design has fewer distinct (h_fi, theta_f) than coefficients), started from
them; the hold-out cases are not used. The neighbour term (:mod:`gearopt.ltca.neighbours`, (N1)): its two
constants by least squares on the logarithm of its decaying part over the fitting cases' responses of the
teeth d = +-1, +-2 at the three rows, its error on the fitting and the hold-out cases, written to
``"neighbour_fit"`` (copied to :data:`gearopt.ltca.neighbours.NEIGHBOUR_FIT`). The fitted coefficients are written to the same file
(``"fit"``), which is where :data:`gearopt.ltca.compliance.FULL_GEAR_FIT`'s numbers come from (copied).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from gearopt.fea import MeshOptions
from gearopt.fea.influence import line_load_compliance
from gearopt.gears import BasicRack, Gear
from gearopt.geometry.generation import generate
from gearopt.ltca.compliance import SAINSOT, Material, ToothCompliance

E, NU = 210000.0, 0.3
M_N, B = 3.0, 2.0
ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "benchmarks" / "data" / "fe_body_fit.json"
MESH = MeshOptions(n_face=2, n_half=6, n_flank=8, n_fillet=5, n_rim=8)
#: (z, x, h_fi = r_f / r_int, role), in the order they are computed (the design spread early)
CASES = [
    (20, 0.0, 2.0, "fit"), (40, 0.0, 2.0, "fit"), (20, 0.0, 1.5, "fit"), (20, 0.0, 3.0, "fit"),
    (14, 0.3, 2.0, "fit"), (30, 0.5, 2.0, "fit"), (30, -0.3, 2.0, "fit"), (25, 0.2, 2.0, "holdout"),
    (20, 0.0, 4.0, "fit"), (60, 0.0, 2.0, "fit"), (40, 0.0, 1.5, "fit"), (40, 0.0, 3.0, "fit"),
    (17, 0.5, 1.5, "fit"), (50, 0.1, 1.7, "holdout"), (14, 0.5, 3.0, "fit"), (40, 0.2, 4.0, "fit"),
    (30, 0.0, 2.5, "fit"), (80, 0.0, 2.0, "fit"), (22, 0.3, 2.5, "holdout"), (60, -0.3, 1.5, "fit"),
    (75, 0.0, 3.0, "fit"), (45, 0.5, 1.5, "fit"), (35, -0.2, 3.0, "holdout"), (17, 0.1, 1.4, "fit"),
    (70, 0.2, 2.5, "fit"), (60, 0.0, 4.0, "fit"), (25, -0.1, 3.5, "holdout"), (20, 0.0, 6.0, "fit"),
    (45, 0.0, 5.0, "fit"), (30, 0.3, 6.5, "fit"), (40, -0.2, 6.0, "holdout"),
]


def case_key(z, x, h_fi) -> str:
    return f"z{z} x{x:+.2f} h{h_fi:.2f}"


def flank_points(tooth, radius):
    """(xy, outward normals) of the right flank at mid face at ``radius`` [mm] (transverse frame)."""
    pr = tooth.transverse_profile(z=0.0, n=2000)["right_flank"]
    rr = np.hypot(pr[:, 0], pr[:, 1])
    o = np.argsort(rr)
    pr, rr = pr[o], rr[o]
    tg = np.gradient(pr, axis=0)
    nrm = np.stack([tg[:, 1], -tg[:, 0]], 1)
    nrm *= np.sign(nrm[:, :1] * pr[:, :1])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    xy = np.stack([np.interp(radius, rr, pr[:, k]) for k in range(2)], 1)
    n = np.stack([np.interp(radius, rr, nrm[:, k]) for k in range(2)], 1)
    return xy, n / np.linalg.norm(n, axis=1, keepdims=True)


def gear_of(z, x) -> Gear:
    return Gear(z=z, m_n=M_N, x=x, b=B, rack=BasicRack.iso53("A"), name=f"z{z}")


def run_case(z, x, h_fi) -> dict:
    """One case's FE bodies at its three loaded rows (see the module docstring)."""
    tooth = generate(gear_of(z, x))
    tc = ToothCompliance(tooth, Material(E=E, nu=NU), tooth.r_root / h_fi, member="gear", body="sainsot2004")
    r_bore = tc.r_int
    t0 = time.perf_counter()
    probe = line_load_compliance(tooth, E, NU, mesh=replace(MESH, rim_depth=0.3), teeth=3, rows=[0], threads=1)
    nr = probe.radius.size
    rows = [1, nr // 2, nr - 1]
    t03 = line_load_compliance(tooth, E, NU, mesh=replace(MESH, rim_depth=0.3), teeth=3, rows=rows, threads=1)
    full = line_load_compliance(tooth, E, NU, mesh=MESH, teeth=z, support="bore", r_bore=r_bore, rows=rows, threads=1)
    r = full.radius[rows]
    xy, n = flank_points(tooth, r)
    body = np.array([full.C[i, i] - t03.C[i, i] for i in rows])
    c = tc.per_width(xy, n)
    return {"z": z, "x": x, "m_n": M_N, "b": B, "h_fi": h_fi, "r_f": tc.r_f, "r_int": r_bore, "theta_f": tc.theta_f,
            "S_f": tc.S_f, "rows": rows, "radius": r.tolist(), "xy": xy.tolist(), "normal": n.tolist(),
            "full": [full.C[i, i] for i in rows], "tooth": [t03.C[i, i] for i in rows], "body": body.tolist(),
            "sainsot2004": c.foundation.tolist(), "eta_F": c.eta_F.tolist(),
            "ccx_s": full.ccx_s + t03.ccx_s, "wall_s": time.perf_counter() - t0}


def far_teeth(z: int) -> tuple[int, ...]:
    """The teeth whose response :func:`run_neighbours` reads: d = -2, -1, 1, 2 and the far teeth -z/4, z/4 and the
    opposite tooth -z//2 (the body's torsion), in the full gear's numbering."""
    d = [-2, -1, 1, 2, -(z // 4), z // 4, -(z // 2)]
    return tuple(sorted({v for v in d if v != 0}))


def run_neighbours(rec: dict) -> dict:
    """The neighbouring teeth's responses of a recorded case's full gear: the same model and load cases as
    :func:`run_case`'s full gear, with the response of teeth :func:`far_teeth` read as well, at the loaded rows
    along each tooth's own normal (:func:`gearopt.fea.influence.line_load_compliance`'s ``neighbours``) [mm^2/N]
    per unit line load; ``own`` is the loaded tooth's own response (the same as the recorded ``full``)."""
    z, x = rec["z"], rec["x"]
    tooth = generate(gear_of(z, x))
    rows = rec["rows"]
    ds = far_teeth(z)
    t0 = time.perf_counter()
    full = line_load_compliance(tooth, E, NU, mesh=MESH, teeth=z, support="bore", r_bore=rec["r_int"], rows=rows,
                                threads=1, neighbours=ds)
    return {"own": [full.C[i, i] for i in rows], **{f"{d:+d}": [full.neighbours[d][i, i] for i in rows] for d in ds},
            "cols": {f"{d:+d}": [full.neighbours[d][:, i].tolist() for i in rows] for d in ds},
            "radius_all": full.radius.tolist(), "ccx_s": full.ccx_s, "wall_s": time.perf_counter() - t0}


def generate_neighbours() -> None:
    """:func:`run_neighbours` for every recorded case that has not got them (``"neighbours"``), the cheapest first
    (resumable: written after every case)."""
    d = load()
    todo = sorted((c["ccx_s"], k) for k, c in d["cases"].items() if "neighbours" not in c)
    for _, key in todo:
        rec = load()["cases"][key]
        try:
            nb = run_neighbours(rec)
        except Exception as exc:  # noqa: BLE001 - a case that cannot be built is reported, the rest go on
            print(f"{key}: neighbours failed: {exc}", flush=True)
            continue
        d = load()
        d["cases"][key]["neighbours"] = nb
        save(d)
        own = np.array(nb["own"])
        print(f"{key} ({rec['role']}): own / recorded {np.round(own / np.array(rec['full']), 6).tolist()}, d+1 / body "
              f"{np.round(np.array(nb['+1']) / np.array(rec['body']), 3).tolist()}, ccx {nb['ccx_s']:.0f} s", flush=True)


def load() -> dict:
    if DATA.exists():
        return json.loads(DATA.read_text())
    return {"_about": "benchmarks/fe_body_fit.py: plane-stress FE full gears held at their bores; body [mm^2/N] per "
                      "unit face width = full gear - tooth (rim 0.3 m_n) at three flank rows; E 210 GPa, nu 0.3",
            "mesh": {k: getattr(MESH, k) for k in ("n_face", "n_half", "n_flank", "n_fillet", "n_rim")},
            "cases": {}}


def save(d: dict) -> None:
    tmp = DATA.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(d, indent=1) + "\n")
    os.replace(tmp, DATA)


def generate_all() -> None:
    for z, x, h, role in CASES:
        d = load()
        key = case_key(z, x, h)
        if key in d["cases"]:
            continue
        try:
            rec = run_case(z, x, h)
        except Exception as exc:  # noqa: BLE001 - a case that cannot be built is reported, the rest go on
            print(f"{key}: failed: {exc}", flush=True)
            continue
        rec["role"] = role
        d = load()
        d["cases"][key] = rec
        save(d)
        print(f"{key} ({role}): body/Sainsot {np.round(np.array(rec['body']) / np.array(rec['sainsot2004']), 3).tolist()}"
              f", ccx {rec['ccx_s']:.0f} s, wall {rec['wall_s']:.0f} s", flush=True)


def members() -> dict:
    """The members of docs/ltca.md section 7's validation (20 or 24 mm wide, 4 face layers, spur and helical),
    their FE bodies at the bore r_f / 2 (full gear - tooth, at the three rows the full gear was loaded at) from
    the line loads of ``benchmarks/fe_full_gear_body.py --validate`` (cached: no CalculiX here when that ran),
    with the inputs of the body term: a check of the fit on other gears and of the helical members' normal
    body against the transverse term."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from fe_full_gear_body import MESH as MESH_V
    from validate_ltca_fe import drives

    from gearopt.meshing.tca import TCA

    out = {}
    for name, (pair, _) in drives().items():
        if "tip relief" in name:
            continue
        tca = TCA(pair)
        for m, (gear, t) in enumerate(((pair.pinion, tca.pinion), (pair.gear, tca.gear)), start=1):
            tooth = t.unmodified
            kw = dict(E=E, nu=NU, r_form=tca.form_radius(m))
            t03 = line_load_compliance(tooth, mesh=replace(MESH_V, rim_depth=0.3), teeth=3, support="sector", **kw)
            r = t03.radius
            cols = [0, r.size // 2, r.size - 1]
            tc = ToothCompliance(tooth, Material(E=E, nu=NU), 0.5 * gear.r_f, body="sainsot2004",
                                 helical="transverse")
            full = line_load_compliance(tooth, mesh=MESH_V, teeth=gear.z, support="bore", r_bore=tc.r_int, rows=cols, **kw)
            xy, n = flank_points(tooth, r[cols])
            c = tc.per_width(xy, n)
            out[f"{name}: {'pinion' if m == 1 else 'gear'}"] = {
                "z": gear.z, "x": gear.x, "m_n": gear.m_n, "b": gear.b, "beta_b": gear.beta_b, "h_fi": tc.h_fi,
                "r_f": tc.r_f, "r_int": tc.r_int, "theta_f": tc.theta_f, "S_f": tc.S_f, "rows": cols,
                "radius": r[cols].tolist(), "xy": xy.tolist(), "normal": n.tolist(),
                "full": [full.C[i, i] for i in cols], "tooth": [t03.C[i, i] for i in cols],
                "body": [full.C[i, i] - t03.C[i, i] for i in cols], "sainsot2004": c.foundation.tolist(),
                "eta_F": c.eta_F.tolist(), "role": "member"}
    return out


def basis(theta_f, h_fi):
    """The six functions of Sainsot's polynomials, (n, 6)."""
    t, h = np.asarray(theta_f, float), np.asarray(h_fi, float)
    return np.stack([1 / t**2, h**2, h / t, 1 / t, h, np.ones_like(t)], -1)


def term(coef, theta_f, h_fi, ratio, tan_g, cos_g, modulus=E):
    """The body term [mm^2/N] with coefficients ``coef`` (4, 6) (rows L, M, P, Q)."""
    L, M, P, Q = (basis(theta_f, h_fi) @ coef[k] for k in range(4))
    return cos_g**2 / modulus * (L * ratio**2 + M * ratio + P * (1.0 + Q * tan_g**2))


def arrays(cases):
    t, h, u, tg, cg, y = [], [], [], [], [], []
    for c in cases:
        n = np.abs(np.array(c["normal"]))
        for k in range(len(c["body"])):
            t.append(c["theta_f"])
            h.append(c["h_fi"])
            u.append(c["eta_F"][k] / c["S_f"])
            cg.append(n[k, 0])
            tg.append(n[k, 1] / n[k, 0])
            y.append(c["body"][k])
    return tuple(np.array(v) for v in (t, h, u, tg, cg, y))


def fit(cases, pull=1e-3):
    """Gauss-Newton on the relative error, with a weak pull (``pull``) towards Sainsot's coefficients (relative
    to their scale) ."""
    t, h, u, tg, cg, y = arrays(cases)
    c0 = np.array([SAINSOT[k] for k in "LMPQ"], float)
    scale = np.maximum(np.abs(c0), 1e-3)
    c = c0.copy()
    for _ in range(30):
        f = term(c, t, h, u, tg, cg)
        res = f / y - 1.0
        J = np.zeros((y.size, 24))
        for i in range(24):
            d = np.zeros(24)
            d[i] = 1e-6 * scale.ravel()[i]
            J[:, i] = (term(c + d.reshape(4, 6), t, h, u, tg, cg) - f) / y / d[i]
        reg = math.sqrt(pull) * np.diag(1.0 / scale.ravel())
        A = np.vstack([J, reg])
        b = np.concatenate([-res, -(reg @ (c - c0).ravel())])
        step = np.linalg.lstsq(A, b, rcond=None)[0]
        c = c + step.reshape(4, 6)
        if np.max(np.abs(step) / scale.ravel()) < 1e-10:
            break
    return c


PULLS = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2)


def choose_pull(cases) -> tuple[float, dict]:
    """The pull towards Sainsot's coefficients with the smallest leave-one-gear-out error (the largest relative
    error of each left-out gear's rows, averaged over the gears) among :data:`PULLS`, on the fitting cases only."""
    cv = {}
    for pull in PULLS:
        errs = []
        for i, c in enumerate(cases):
            coef = fit(cases[:i] + cases[i + 1:], pull)
            t, h, u, tg, cg, y = arrays([c])
            errs.append(float(np.max(np.abs(term(coef, t, h, u, tg, cg) / y - 1.0))))
        cv[pull] = float(np.mean(errs))
        print(f"pull {pull:g}: leave-one-gear-out error, mean of the gears' largest {100 * cv[pull]:.2f} %, "
              f"largest {100 * max(errs):.2f} %", flush=True)
    return min(cv, key=cv.get), cv


def report(d, coef) -> dict:
    out = {}
    for role in ("fit", "holdout"):
        cs = [c for c in d["cases"].values() if c.get("role") == role]
        if not cs:
            continue
        t, h, u, tg, cg, y = arrays(cs)
        e_new = term(coef, t, h, u, tg, cg) / y - 1.0
        e_old = term(np.array([SAINSOT[k] for k in "LMPQ"]), t, h, u, tg, cg) / y - 1.0
        out[role] = {"n_cases": len(cs), "max_abs_err": float(np.max(np.abs(e_new))),
                     "rms_err": float(np.sqrt(np.mean(e_new**2))), "sainsot2004_err_range": [float(e_old.min()),
                                                                                              float(e_old.max())]}
        print(f"{role}: {len(cs)} gears, {y.size} rows; fitted term / FE body - 1: max |.| {100 * np.max(np.abs(e_new)):.2f} %,"
              f" rms {100 * np.sqrt(np.mean(e_new**2)):.2f} %; Sainsot 2004: {100 * e_old.min():+.1f} to "
              f"{100 * e_old.max():+.1f} %")
        for c in cs:
            tt, hh, uu, tgg, cgg, yy = arrays([c])
            en = term(coef, tt, hh, uu, tgg, cgg) / yy - 1
            print(f"  {case_key(c['z'], c['x'], c['h_fi']):<20} theta_f {c['theta_f']:.4f}: FE body "
                  + " ".join(f"{1e3 * v:.4f}" for v in yy) + " um mm/N; Sainsot / FE "
                  + " ".join(f"{s / v:.3f}" for s, v in zip(c["sainsot2004"], yy)) + "; fit err "
                  + " ".join(f"{100 * e:+.1f}%" for e in en))
    return out


def neighbour_arrays(cases):
    """Per case and row the FE neighbours' responses d = +-1, +-2 and the inputs of (N1)
    (:class:`gearopt.ltca.neighbours.NeighbourTerm`, the fitted body term at the pitch point): arrays
    ``(key, d, row, y, c_tw, c_body, x)``, one entry per (case, d, row)."""
    from gearopt.ltca.neighbours import NeighbourTerm

    out = {k: [] for k in ("key", "d", "row", "y", "c_tw", "c_body", "x")}
    for c in cases:
        tooth = generate(gear_of(c["z"], c["x"]))
        tc = ToothCompliance(tooth, Material(E=E, nu=NU), c["r_int"], member="gear")
        t = NeighbourTerm.of(tc, tooth)
        for d in (-2, -1, 1, 2):
            for i, y in enumerate(c["neighbours"][f"{d:+d}"]):
                for k, v in zip(out, (case_key(c["z"], c["x"], c["h_fi"]), d, i, y, t.c_tw, t.c_body, t.x)):
                    out[k].append(v)
    return {k: np.array(v) for k, v in out.items()}


def fit_neighbours(d: dict) -> dict:
    """(N1)'s constants (A, k) by least squares on ``log((n - c_tw) / (c_body - c_tw)) = log A - k |d| x`` over
    the fitting cases' d = +-1, +-2 responses at their three rows; the relative error of (N1) on the fitting and
    the hold-out cases (the same split as the body term), the far teeth against the torsion, and the
    plane-stress 20/40 members against the 3D full gears of benchmarks/data/fe_neighbour_teeth.json."""
    from gearopt.ltca.neighbours import NEIGHBOUR_FIT

    roles = {r: [c for c in d["cases"].values() if c.get("role") == r and "neighbours" in c] for r in ("fit", "holdout")}
    a = neighbour_arrays(roles["fit"])
    q = (a["y"] - a["c_tw"]) / (a["c_body"] - a["c_tw"])
    X = np.stack([np.ones(q.size), -np.abs(a["d"]) * a["x"]], 1)
    sol = np.linalg.lstsq(X, np.log(q), rcond=None)[0]
    A, k = float(np.exp(sol[0])), float(sol[1])
    out = {"A": A, "k": k, "form": "n(d) = c_tw + A exp(-k |d| s_f / (r_f - r_int)) (c_body - c_tw)",
           "fit_cases": sorted(case_key(c["z"], c["x"], c["h_fi"]) for c in roles["fit"]),
           "in_code": list(NEIGHBOUR_FIT)}
    print(f"(N1) fitted on {len(roles['fit'])} gears ({q.size} values): A = {A:.4f}, k = {k:.4f} "
          f"(gearopt.ltca.neighbours.NEIGHBOUR_FIT: {NEIGHBOUR_FIT})")
    for role, cs in roles.items():
        if not cs:
            continue
        b = neighbour_arrays(cs)
        model = b["c_tw"] + A * np.exp(-k * np.abs(b["d"]) * b["x"]) * (b["c_body"] - b["c_tw"])
        e = model / b["y"] - 1.0
        st = {"n_cases": len(cs), "n_values": int(e.size), "max_abs_err": float(np.max(np.abs(e))),
              "rms_err": float(np.sqrt(np.mean(e**2))),
              **{f"max_abs_err_d{v}": float(np.max(np.abs(e[np.abs(b["d"]) == v]))) for v in (1, 2)}}
        out[role] = st
        print(f"{role}: {len(cs)} gears, {e.size} values: (N1) / FE - 1 max |.| {100 * st['max_abs_err']:.1f} % "
              f"(d = 1: {100 * st['max_abs_err_d1']:.1f} %, d = 2: {100 * st['max_abs_err_d2']:.1f} %), "
              f"rms {100 * st['rms_err']:.1f} %")
        for key in dict.fromkeys(b["key"]):
            j = b["key"] == key
            c = d["cases"][key]
            far = -(c["z"] // 2)
            tw = c["neighbours"][f"{far:+d}"]
            print(f"  {key:<20} FE d=+1 " + " ".join(f"{1e3 * v:.4f}" for v in c["neighbours"]["+1"])
                  + ", d=+2 " + " ".join(f"{1e3 * v:.4f}" for v in c["neighbours"]["+2"])
                  + f" um mm/N; (N1) d=1 {1e3 * model[j & (b['d'] == 1)][0]:.4f}, d=2 {1e3 * model[j & (b['d'] == 2)][0]:.4f}"
                  + f"; err {100 * e[j].min():+.1f} to {100 * e[j].max():+.1f} %; opposite tooth d={far} "
                  + " ".join(f"{1e3 * v:.4f}" for v in tw) + f" / torsion {1e3 * b['c_tw'][j][0]:.4f}")
    tw = []
    for c in d["cases"].values():
        if "neighbours" in c:
            far = -(c["z"] // 2)
            bb = neighbour_arrays([c])
            tw += [v / bb["c_tw"][0] for v in c["neighbours"][f"{far:+d}"]]
    if tw:
        out["opposite_over_torsion"] = [float(min(tw)), float(max(tw))]
        print(f"the opposite tooth's response over the torsion c_tw, every gear and row: {min(tw):.3f} to {max(tw):.3f}")
    # the plane-stress gears against the 3D full gears of the validation's members (same z, x, bore; b 2 vs 20 mm)
    p3 = ROOT / "benchmarks" / "data" / "fe_neighbour_teeth.json"
    if p3.exists():
        m3 = json.loads(p3.read_text())["members"]
        cmp = {}
        for key3, z in (("20 teeth (spur 20/40 conjugate)", 20), ("40 teeth (spur 20/40 conjugate)", 40)):
            c = d["cases"].get(case_key(z, 0.0, 2.0))
            if c is None or "neighbours" not in c or key3 not in m3:
                continue
            r2 = np.array(c["radius"])
            rows = []
            for i, r in enumerate(m3[key3]["rows_mm"]):
                j = int(np.argmin(np.abs(r2 - r)))
                if abs(r2[j] - r) > 0.01:
                    continue
                rows.append({"radius": r, **{f"{dd:+d}": [1e3 * c["neighbours"][f"{dd:+d}"][j], m3[key3][f"full {dd:+d}"][i]]
                                             for dd in (-2, -1, 1, 2)}})
            cmp[key3] = rows
            for row in rows:
                print(f"  {key3} row {row['radius']:.3f} mm: plane stress / 3D [um mm/N] " + ", ".join(
                    f"d {dd:+d} {row[f'{dd:+d}'][0]:.4f} / {row[f'{dd:+d}'][1]:.4f} ({100 * (row[f'{dd:+d}'][0] / row[f'{dd:+d}'][1] - 1):+.1f} %)"
                    for dd in (-2, -1, 1, 2)))
        out["plane_stress_vs_3d"] = cmp
    return out


def main(argv) -> int:
    if "-h" in argv or "--help" in argv:
        print(__doc__)
        return 0
    if "--generate-neighbours" in argv or "--neighbours" in argv:
        if "--generate-neighbours" in argv:
            generate_neighbours()
        d = load()
        d["neighbour_fit"] = {**fit_neighbours(d), "date": time.strftime("%Y-%m-%d"),
                              "command": "python benchmarks/fe_body_fit.py --neighbours"}
        if "--generate-neighbours" in argv or "--record" in argv:
            save(d)
        return 0
    bad = [a for a in argv if a not in ("--fit", "--generate")]
    if bad:
        print(f"fe_body_fit.py: unknown argument {bad[0]!r}: expected --fit or --generate (see --help)", file=sys.stderr)
        return 2
    if "--fit" not in argv:
        generate_all()
        d = load()
        if "members" not in d:
            d["members"] = members()
            save(d)
    if "--generate" in argv:
        return 0
    d = load()
    fit_cases = [c for c in d["cases"].values() if c.get("role") == "fit"]
    if len(fit_cases) < 4:
        print(f"fe_body_fit.py: {len(fit_cases)} fitting cases recorded, at least 4 needed", file=sys.stderr)
        return 1
    pull, cv = choose_pull(fit_cases)
    coef = fit(fit_cases, pull)
    print(f"the fit with pull {pull:g}:")
    stats = report(d, coef)
    d["fit"] = {"coefficients": {k: coef[i].tolist() for i, k in enumerate("LMPQ")}, "stats": stats,
                "pull": pull, "leave_one_gear_out": {f"{k:g}": v for k, v in cv.items()},
                "theta_f_range": [min(c["theta_f"] for c in fit_cases), max(c["theta_f"] for c in fit_cases)],
                "fit_cases": sorted(case_key(c["z"], c["x"], c["h_fi"]) for c in fit_cases),
                "date": time.strftime("%Y-%m-%d")}
    save(d)
    print("coefficients (A, B, C, D, E, F):")
    for i, k in enumerate("LMPQ"):
        print(f'    "{k}": (' + ", ".join(f"{v:.6g}" for v in coef[i]) + "),")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
