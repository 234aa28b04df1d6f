"""Sensitivities of the loaded micro-geometry optimum to a misalignment added to every case
(``LoadedMicroOptimizer.sensitivities``, docs/loaded_synthesis.md section 6) against central finite
differences of re-solved optima, on every loaded_microgeometry scene and on problems/optimize_microgeometry.py.

For each scene the optimum is solved (``opt.solve()``), then again for the duty cycle with every case
offset by ``+h`` and ``-h`` of one misalignment kind (``opt.shifted``), each from the optimum and on its
final grid of positions (so the grid does not change between the three). The central difference
``(theta(+h) - theta(-h)) / 2h`` and the one-sided ones ``(theta(+-h) - theta) / +-h`` are printed with the
AD derivative. A centre distance cannot shrink below the zero-backlash one (the scenes sit on it): for
``dE`` the offsets are ``h`` and ``2h`` and the difference the second-order forward one. Every optimum
of the differences (the zero point and each re-solved one) is taken from where its loop stops to the
loop's fixed point (:func:`fixed_point`: the NLP built around it has its optimum there, to
``--theta-tol``, default 1e-7 mm); the derivatives are evaluated at that zero point. A difference
quotient is then known to about ``THETA_TOL / h`` (``4 THETA_TOL / h`` forward): the agreement is
judged against that. (Where each loop stops, ``--no-settle``, an optimum may lie a few nm off its
fixed point whatever ``THETA_TOL`` says: problems/optimize_microgeometry.py's 3 nm of root relief gave
6 um per mm over h = 0.5 um, docs/loaded_synthesis.md section 6.4.) The loop itself runs with
``THETA_TOL`` = ``--theta-tol`` and without its stop on a negligible predicted decrease, so that small
steps (default 0.01 arcmin, 0.005 mm) stay within one active set and above the noise. The steps are
cut to the range over which the sensitivities' active set holds (``range_mis`` of
``LoadedMicroOptimizer.sensitivities``, first order), and where that range is short the optimum is
re-solved beyond it to confirm the flagged change (:func:`fd_check`). A scene with a Pareto front is
checked at the design it reports (the front's anchor, under the limit whose NLP it solves:
:func:`reported`; ``--no-pareto``: the optimum without a limit).

    python benchmarks/loaded_sensitivity_fd.py                       # 4 scenes x crossing, dE (~40 min alone)
    python benchmarks/loaded_sensitivity_fd.py --only microgeometry_pareto --kinds crossing
    python benchmarks/loaded_sensitivity_fd.py --only microgeometry_pareto --no-pareto   # its range of 1.06 um of dE
    python benchmarks/loaded_sensitivity_fd.py --h-angle 0.05 --h-length 0.05 --theta-tol 1e-4   # the issue's steps

``--h-angle`` [arcmin] and ``--h-length`` [mm] are the steps. Each re-solved optimum's active set
(the active rows of each constraint block, the amounts on a bound, the active and tip-edge slices per
case) is compared with the optimum's, and the one-sided quotients over the two steps with each other:
where a loop stopped on its trust radius, the active set or the slice set changes, or the quotients
disagree (a kink or another local optimum), the kind is reported as not compared (:func:`verdict`).
Exit status 1 when a compared AD derivative is off the difference by more than twice the noise bound
plus 5 % of the difference (docs/loaded_synthesis.md sections 6.3, 6.4).

    python benchmarks/loaded_sensitivity_fd.py --only optimize_microgeometry --kinds dE --h-length 0.001 --theta-tol 1e-8
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: the loaded_microgeometry scenes (problems/*.toml) and the script problems/optimize_microgeometry.py
SCENES = ("microgeometry_loaded", "microgeometry_pareto", "microgeometry_te_target", "optimize_microgeometry")


def build_optimizer(name: str):
    """The scene's optimiser: a problems/<name>.toml scene's, or that of problems/optimize_microgeometry.py
    (its drive, free amounts, duty cycle and options restated here: that script builds its study inside
    ``main``; aligned and 2 arcmin crossed, no mirror image, so the full problem's KKT system)."""
    if name != "optimize_microgeometry":
        from gearopt.io.scene import load_scene

        return load_scene(ROOT / "problems" / f"{name}.toml").build().optimizer
    from gearopt import ARCMIN, Gear, GearPair, LoadedMicroStudy, Microgeometry, misalignment_cases

    um = 1e-3
    start = Microgeometry(C_alpha=5 * um, C_beta=10 * um, d_Ca=64.0, d_Cf=58.5)
    pair = GearPair(Gear(z=20, m_n=3.0, b=20, name="pinion", modifications=start),
                    Gear(z=40, m_n=3.0, b=20, name="gear"))
    free = {f"pinion.{a}": (0.0, 40 * um) for a in ("C_alpha", "C_beta", "C_alpha_a", "C_alpha_f")}
    cases = {k: v for k, v in misalignment_cases(crossing=2 * ARCMIN).items() if not k.startswith("crossing -")}
    return LoadedMicroStudy(pair, free, torque=250.0, torques=[100.0, 250.0], cases=cases, edge_margin=0.5 * um,
                            n_positions=16, n_verify=32, n_slices=11, name="optimize_microgeometry").optimizer


def reported(name: str, opt, design):
    """The optimiser and design whose sensitivities the scene reports: for a scene with a Pareto front
    (``pareto`` limits) the front's anchor, which may be a tighter limit's design, with the optimiser of
    the limit whose NLP it solves (``ParetoFront.solved_under``, as ``LoadedMicroStudy`` does); else
    ``(opt, design)``."""
    if name == "optimize_microgeometry":
        return opt, design
    from gearopt.io.scene import load_scene

    limits = load_scene(ROOT / "problems" / f"{name}.toml").build().pareto
    if limits is None or opt.p_limit is not None:
        return opt, design
    fr = opt.pareto(limits, anchor=design)
    under = fr.solved_under[0] if fr.solved_under else None
    print(f"Pareto front: the anchor {fr.anchor.theta_um()} um solves the NLP of the limit {under} MPa "
          f"(the optimum without a limit: {design.theta_um()} um)")
    return (opt if under is None else opt.with_p_limit(under)), fr.anchor


def active_set_of(S: dict) -> dict:
    """The active set of a ``kkt_sensitivities`` result: the active rows of each constraint block of its
    NLP, the free amounts on a bound, the positions of the loaded TE's extremes and per case the active
    slices and tip-edge slices (a slice whose point crosses a flank's end or a tip changes the NLP's
    slices) (its ``active_rows``, ``active_bounds``, ``slices``, ``peaks``)."""
    return {"rows": S["active_rows"], "bounds": S["active_bounds"], "slices": S["slices"], "peaks": S["peaks"]}


def active_set(opt, design) -> dict | str:
    """:func:`active_set_of` the NLP's own derivatives at ``design`` (``held=False``: only the active set
    is read), or the error text."""
    from gearopt.errors import SynthesisError

    try:
        S = opt.kkt_sensitivities(design, held=False, derivatives=False)
    except SynthesisError as exc:
        return str(exc)[:120]
    return active_set_of(S)


#: the most NLP solves of :func:`fixed_point` (its map contracts by about tenfold per solve)
FIXED_POINT_ITERATIONS = 8


def fixed_point(opt, design, tol: float) -> tuple:
    """The loop's optimum settled to ``tol`` [mm]: the design whose NLP (built around it with every
    active slice and no trust radius: ``kkt_sensitivities``'s, here ``held=False``) has its optimum
    there, by the fixed-point iteration ``theta <- argmin NLP(theta)`` from ``design`` (a ``MicroDesign``).

    The trust-region loop stops where the NLP's step falls below ``THETA_TOL`` or where its predicted
    decrease (the exact merit minus the model's optimum) falls below ``F_TOL`` of the merit, and it
    accepts a step only where the exact loaded TCA confirms a tenth of the predicted decrease. At steps
    of a few nm both tests read noise: the model's optimum may lie above the exact merit (the smoothing),
    so the loop stops at once ("converged") or rejects every step ("trust radius") a few nm from its
    fixed point (problems/optimize_microgeometry.py: 3.1-3.5 nm of root relief, which over a step of
    h = 0.5 um of dE is 6-7 um per mm). The differences here need the fixed point itself.

    Returns ``(design, S, status)``: the settled design (``design`` with the NLP's ``theta``), the
    ``kkt_sensitivities(held=False)`` result there (its ``objective`` the NLP's optimum) and ``"fixed
    point"`` or ``"not settled"`` (no step below ``tol`` within :data:`FIXED_POINT_ITERATIONS`, or an NLP
    failed)."""
    import dataclasses

    from gearopt.errors import SynthesisError

    names = list(opt.free)
    S = None
    for _ in range(FIXED_POINT_ITERATIONS):
        try:
            # (the NLP's optimum and active set only: the KKT system of a mirror-image duty cycle's full
            # problem is singular, Sensitivities.sensitivities, and is not needed here)
            S = opt.kkt_sensitivities(design, held=False, derivatives=False)
        except SynthesisError:
            return design, S, "not settled"
        th = S["nlp"].layout.unknowns.take(S["z"], "theta") * 1e-3
        design = dataclasses.replace(design, theta=dict(zip(names, (float(v) for v in th))))
        if S["model_step"] <= tol:
            return design, S, "fixed point"
    return design, S, "not settled"


def verdict(r: dict, base_set, odd: bool, base_stop: str = "converged") -> tuple[bool | None, str]:
    """Whether the AD derivatives agree with the differences (None: not compared) and why.

    Not compared where a loop (the optimum's or a re-solved one's) stopped on its trust radius (its
    optimum is not known to ``THETA_TOL``: the differences are not bounded by the noise bound), where
    the re-solved optima lie on another active set than the optimum (a bound or a
    constraint block's count of active rows changes) or jump (the one-sided difference quotients over
    the two steps differ by more than a quarter of the largest difference plus four noise bounds: a
    kink or another local optimum within the steps). A mirror-odd kind of a mirror-symmetric duty
    cycle is compared by its central difference even so (the optimum is even in the offset there,
    section 6.1: its one-sided quotients are those of a kink, the reported derivative the central one).
    Else: within twice the noise bound plus 5 % of the difference."""
    ad, fd = np.array(r["ad_um"]), np.array(r["fd_um"])
    noise = r["noise_um"]
    stops = [base_stop] + list(r["stops"])
    if any(s not in ("converged", "fixed point") for s in stops) and not odd:
        return None, f"not compared: a loop stopped on its trust radius (optimum, re-solved: {stops})"
    sets = [s for s in r["active_sets"] if s is not None]
    if base_set is not None and sets:
        bad = [s for s in sets if isinstance(s, str)]
        if bad:
            return None, f"not compared: the active set of a re-solved optimum is unknown ({bad[0]})"
        changed = [s for s in sets if s != base_set]
        if changed and not odd:
            return None, (f"not compared: the re-solved optimum's active set or slice set changes within the steps "
                          f"(optimum {base_set}, re-solved {changed[0]})")
    if not odd and noise > 0.25 * np.max(np.abs(ad)):
        return None, (f"not compared: the sensitivities' active set holds over {r['range']} only (their range_mis), "
                      f"where the differences' noise bound {noise:.3g} um per unit exceeds a quarter of AD")
    jump = np.abs(np.array(r["plus_um"]) - np.array(r["other_um"]))
    if np.any(jump > 0.25 * np.max(np.abs(fd)) + 4 * noise) and not odd:
        return None, (f"not compared: the one-sided differences disagree by up to {np.max(jump):.3g} um per unit "
                      "(a kink or a jump to another local optimum within the steps)")
    ok = bool(np.all(np.abs(ad - fd) <= 2 * noise + 0.05 * np.abs(fd)))
    return ok, f"agreement within 2 x noise + 5 %: {ok}"


def fd_check(opt, design, sens, kind: str, h: float, check_sets: bool = True, base=None,
             base_objective: float | None = None, settle: bool = True, base_set=None) -> dict:
    """AD against finite differences of re-solved optima for one kind (``h`` in mm or rad); ``base``:
    the optimum re-solved without an offset as the others are (from ``design`` on its grid), whose
    design and objective (``base_objective``, default its ``predicted["objective"]``) are the
    differences' zero point (default ``design``). ``settle``: each re-solved optimum taken to its fixed
    point (:func:`fixed_point`; its status replaces the loop's stop).

    The steps stay within the range over which the sensitivities' active set holds (their
    ``range_mis``: to first order, where an active inequality's multiplier or an inactive one's slack
    crosses zero): ``h`` is cut to 0.8 of the range for a central difference, 0.4 for the forward one's
    ``2h``. Where that range lies within ten requested steps, the optimum is re-solved at 1.5 times its
    edge (each side) and its active set compared with ``base_set`` (the zero point's): ``beyond`` says
    whether it changed there, i.e. whether the flagged event is the optimum's."""
    from gearopt.meshing.misalignment import Misalignment

    from gearopt.errors import GeometryError

    names = list(opt.free)
    theta = np.array([design.theta[n] for n in names])
    base = design if base is None else base
    theta0 = np.array([base.theta[n] for n in names])
    obj0 = base.predicted["objective"] if base_objective is None else base_objective
    j = Misalignment.names().index(kind)
    try:  # a centre distance below the zero-backlash one is refused: forward differences there
        Misalignment(**{kind: -h}).check(opt.pair, "mis")
        steps = (1, -1)
    except GeometryError:
        steps = (1, 2)
    h_req = h
    lo, hi = (float(v) for v in sens["range_mis"][j])
    if np.isfinite(lo) or np.isfinite(hi):  # (NaN: a mirror-odd kind, zero by the symmetry)
        h = min(h, 0.4 * hi) if steps == (1, 2) else min(h, 0.8 * min(hi, -lo))
    beyond = []
    for edge in ((hi,) if steps == (1, 2) else (lo, hi)):
        if check_sets and base_set is not None and np.isfinite(edge) and abs(edge) < 10 * h_req:
            o = opt.shifted(Misalignment(**{kind: 1.5 * edge}))
            d = o.solve(start=theta, grid=design.phi1)
            d, S, stop = fixed_point(o, d, opt_theta_tol()) if settle else (d, None, d.stop)
            now = active_set_of(S) if S is not None else active_set(o, d)
            beyond.append({"offset": 1.5 * edge, "changed": now != base_set, "stop": stop})
    out, sets = {}, {}
    for sgn in steps:
        o = opt.shifted(Misalignment(**{kind: sgn * h}))
        d = o.solve(start=theta, grid=design.phi1)
        if settle:
            d, S, stop = fixed_point(o, d, opt_theta_tol())
            obj = float("nan") if S is None else S["objective"]
            sets[sgn] = (active_set_of(S) if S is not None else "no NLP solution") if check_sets else None
        else:
            obj, stop = d.predicted["objective"], d.stop
            sets[sgn] = active_set(o, d) if check_sets else None
        out[sgn] = (np.array([d.theta[n] for n in names]), obj, stop)
    if steps == (1, -1):
        # central difference, and the one-sided ones
        fd = (out[1][0] - out[-1][0]) / (2 * h)
        fd_f = (out[1][1] - out[-1][1]) / (2 * h)
        other = (theta0 - out[-1][0]) / h
        noise = opt_theta_tol() / h
    else:
        # second-order forward difference (-3 f(0) + 4 f(h) - f(2h)) / 2h, and the one-sided one over 2h
        fd = (-3 * theta0 + 4 * out[1][0] - out[2][0]) / (2 * h)
        fd_f = (-3 * obj0 + 4 * out[1][1] - out[2][1]) / (2 * h)
        other = (out[2][0] - theta0) / (2 * h)
        noise = 4 * opt_theta_tol() / h
    return {"kind": kind, "h": h, "difference": "central" if steps == (1, -1) else "forward (2nd order)",
            "ad_um": (sens["d_theta_d_mis"][:, j] * 1e3).tolist(), "fd_um": (fd * 1e3).tolist(),
            "plus_um": ((out[1][0] - theta0) / h * 1e3).tolist(), "other_um": (other * 1e3).tolist(),
            "noise_um": float(noise * 1e3), "ad_objective": float(sens["d_objective_d_mis"][j]),
            "fd_objective": float(fd_f), "stops": [out[k][2] for k in steps], "names": names,
            "active_sets": [sets[k] for k in steps], "h_requested": h_req, "range": [lo, hi],
            "range_why": sens["range_why"]["mis"][j], "beyond": beyond}


def opt_theta_tol() -> float:
    from gearopt.synthesis.loaded import constants

    return constants.THETA_TOL


def main(argv=None) -> int:
    from gearopt.errors import SynthesisError
    from gearopt.units import ARCMIN

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", default=None, help="one scene name (default: all four)")
    ap.add_argument("--kinds", default="crossing,dE", help="misalignment kinds, comma-separated")
    ap.add_argument("--h-angle", type=float, default=0.01, help="step of an angle [arcmin]")
    ap.add_argument("--h-length", type=float, default=0.005, help="step of a length [mm]")
    ap.add_argument("--out", default=None, help="write the records as JSON here")
    ap.add_argument("--theta-tol", type=float, default=1e-7,
                    help="the loop's design tolerance THETA_TOL for every solve here [mm] (default 1e-7; the "
                         "optimiser's own is 1e-4: differences of optima solved to it are noise below ~0.1 um)")
    ap.add_argument("--no-active-sets", action="store_true",
                    help="do not compare the re-solved optima's active sets with the optimum's (saves one "
                         "sensitivities' NLP per solve)")
    ap.add_argument("--no-settle", action="store_true",
                    help="take each optimum where its trust-region loop stops instead of at its fixed point "
                         "(fixed_point: the loop may stop a few nm from it, which small steps amplify)")
    ap.add_argument("--no-pareto", action="store_true",
                    help="a scene with a Pareto front: check the optimum without a pressure limit instead of the "
                         "design the scene reports (the front's anchor, under the limit whose NLP it solves)")
    a = ap.parse_args(argv)
    from gearopt.synthesis.loaded import constants

    # every optimum here (the base and the re-solved ones) converged to a tight tolerance: the loop stops
    # on its step alone (F_TOL, the predicted decrease, made negligible)
    constants.THETA_TOL, constants.F_TOL = a.theta_tol, 1e-12
    from gearopt.meshing.misalignment import Misalignment

    kinds = [k.strip() for k in a.kinds.split(",") if k.strip()]
    bad = [k for k in kinds if k not in Misalignment.names()]
    if bad:
        ap.error(f"--kinds: unknown kind(s) {bad}; valid: {list(Misalignment.names())}")
    scenes = SCENES if a.only is None else tuple(s for s in SCENES if s == a.only)
    if not scenes:
        ap.error(f"--only {a.only!r}: valid: {list(SCENES)}")
    records, fail = [], False
    for name in scenes:
        t0 = time.perf_counter()
        opt = build_optimizer(name)
        design = opt.solve()
        if not a.no_pareto:
            opt, design = reported(name, opt, design)
        theta = np.array([design.theta[n] for n in opt.free])
        if a.no_settle:
            # the zero point of the differences: the optimum re-solved as the offset ones are (from the
            # optimum, on its grid), each where its loop stops
            base = opt.shifted(Misalignment()).solve(start=theta, grid=design.phi1)
            base_obj, base_stop = base.predicted["objective"], base.stop
            base_set = None if a.no_active_sets else active_set(opt, design)
        else:
            # the zero point: the optimum's fixed point (the loop may stop a few nm from it, fixed_point)
            base, Sb, base_stop = fixed_point(opt, design, a.theta_tol)
            base_obj = float("nan") if Sb is None else Sb["objective"]
            base_set = None if a.no_active_sets or Sb is None else active_set_of(Sb)
        # the derivatives at the zero point
        sens = opt.sensitivities(base)
        print(f"zero point: {base.theta_um()} um, {base_stop} (the loop stopped {design.stop} at "
              f"{design.theta_um()} um)")
        print(f"\n## {name}: optimum {design.theta_um()} um, stop {design.stop}, mirror-odd kinds by symmetry "
              f"{sens['mirror_odd']}, degenerate {sens['degenerate']}, active {sens['active']}")
        for kind in kinds:
            angle = Misalignment.meta(kind)["unit"] == "angle"
            unit, scale = ("arcmin", ARCMIN) if angle else ("mm", 1.0)
            h = (a.h_angle if angle else a.h_length) * scale
            try:
                r = fd_check(opt, design, sens, kind, h, check_sets=not a.no_active_sets, base=base,
                             base_objective=base_obj, settle=not a.no_settle, base_set=base_set)
            except SynthesisError as exc:  # e.g. no design keeps the edges open at the offset
                print(f"\n{kind} (h = {h / scale:g} {unit}): a re-solve failed: {str(exc)[:300]}")
                records.append({"scene": name, "kind": kind, "h": h, "error": str(exc)})
                continue
            r["scene"] = name
            records.append(r)
            lo, hi = r["range"]
            print(f"\n{kind}: the sensitivities' active set holds over {lo / scale:.4g} ... {hi / scale:.4g} {unit} "
                  f"(events at its ends: {r['range_why'][0]}; {r['range_why'][1]}); beyond it, re-solved: "
                  + ", ".join(f"{b['offset'] / scale:.4g} {unit} active set changed {b['changed']} ({b['stop']})"
                              for b in r["beyond"]))
            h = r["h"]
            print(f"\n{kind} (h = {h / scale:g} {unit}, {r['difference']} difference; noise bound "
                  f"{r['noise_um'] * scale:.3g} um per {unit}; re-solved loops: {r['stops']})")
            other = "one-sided -h" if r["difference"] == "central" else "one-sided 2h"
            print(f"| amount | AD [um/{unit}] | FD | one-sided +h | {other} |")
            print("|---|---|---|---|---|")
            for i, n in enumerate(r["names"]):
                print(f"| {n} | {r['ad_um'][i] * scale:.4g} | {r['fd_um'][i] * scale:.4g} | "
                      f"{r['plus_um'][i] * scale:.4g} | {r['other_um'][i] * scale:.4g} |")
            print(f"| objective [arcsec/{unit}] | {r['ad_objective'] * scale:.4g} | {r['fd_objective'] * scale:.4g} | | |")
            r["ok"], why = verdict(r, base_set, kind in sens["mirror_odd"], base_stop)
            fail |= r["ok"] is False
            print(why)
        print(f"({time.perf_counter() - t0:.0f} s)")
        sys.stdout.flush()
    if a.out:
        Path(a.out).write_text(json.dumps(records, indent=1))
    return 1 if fail else 0


if __name__ == "__main__":
    sys.exit(main())
