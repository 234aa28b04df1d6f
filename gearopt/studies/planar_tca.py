"""Study ``planar_tca``: TCA of two planar involute profiles (Litvin & Fuentes, Problem 9.4.1).

Scene section ``[planar_tca]`` (all optional):

``r_b1``, ``r_b2``  base radii of the driving gear 1 and the driven gear 2 (mm); default: the base
                    radii of ``[pinion]`` and ``[gear]``.
``E``               centre distance (mm), > r_b1 + r_b2; default the pair's centre distance ``a``.
``phi1_min``, ``phi1_max``  range of the rotation of gear 1 (deg); default: the contact point runs
                    over the middle 80 % of the segment T1 T2 between the base-circle tangency points.
                    Valid: ``-alpha < phi1 < E sin(alpha)/r_b1 - alpha`` with
                    ``cos alpha = (r_b1 + r_b2)/E`` (theta1, theta2 > 0 on both profiles).
``n``               number of positions (default 41).
``method``          "continuation" (warm starts with the AD tangent, default) or "map" (all
                    positions in one mapped rootfinder call).
``alpha_guess``     pressure angle assumed by the starting point of Newton (deg; default 20).
``profiles``        number of positions at which the two profiles are drawn (default 3).

The scene loader requires ``[pinion]``, ``[gear]`` and ``[pair]`` for every study; this study uses
them only for the defaults above. When ``r_b1``/``r_b2``/``E`` are given and differ from the pair,
the given values are used and ``results.json`` says so under ``notes``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import GeometryError, SceneError
from ..meshing.planar import PlanarTCA, PlanarTCAResult, closed_form, profile_points
from ..settings import PlanarTCASettings
from ..summary import KeyNumber, planar_tca_summary
from ..units import DEG

UNITS = {"length": "mm", "angle": "rad (suffix _deg: degrees)", "te": "rad", "te_arcsec": "arcsec",
         "ratio": "-", "time": "s", "profiles": "mm, fixed frame S_f (O1 at the origin, O2 = (0, E))"}


@dataclass(frozen=True)
class PlanarTCAReport:
    """Result of the ``planar_tca`` study: the solved TCA plus profile polylines for the plots."""

    scene: str
    tca: PlanarTCAResult
    profiles: list = field(repr=False)
    notes: list = field(default_factory=list)
    timing: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        t = self.tca
        d = t.to_dict()
        units = {**d.pop("units"), **UNITS}
        lo = d["derived"]["line_of_action"]
        if lo["angle"] is not None:
            lo["angle_deg"] = lo["angle"] / DEG
        return {"study": "planar_tca", "scene": self.scene, "units": units, **d,
                "profiles": self.profiles, "notes": list(self.notes),
                "timing": {**d["timing"], **self.timing}}

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "line_of_action.png": "Base and operating pitch circles, the profiles and the solved contact points (Litvin "
                              "Fig. 9.4.5), with the meshing zone enlarged: read that the contact points lie on one "
                              "straight line of action, tangent to both base circles.",
        "transmission_error.png": "Transmission error at the solved positions: read that it is zero up to round-off "
                                  "(conjugate involute profiles, constant ratio m12).",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.planar_tca_summary`), read from :meth:`to_dict`."""
        return planar_tca_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """Write ``line_of_action.png`` (Fig. 9.4.5) and ``transmission_error.png`` into ``out_dir``."""
        from pathlib import Path

        import matplotlib.pyplot as plt

        from ..plot.planar import plot_line_of_action, plot_transmission_error

        out = Path(out_dir)
        fig, axes = plt.subplots(1, 2, figsize=(14, 8.5), gridspec_kw={"width_ratios": [1, 1.15]})
        plot_line_of_action(self, ax=axes[0])
        plot_line_of_action(self, ax=axes[1], zoom=True)
        fig.tight_layout()
        fig.savefig(out / "line_of_action.png", dpi=dpi, bbox_inches="tight")
        plt.close(fig)

        fig, ax = plt.subplots(figsize=(8, 4.5))
        plot_transmission_error(self, ax=ax)
        fig.tight_layout()
        fig.savefig(out / "transmission_error.png", dpi=dpi, bbox_inches="tight")
        plt.close(fig)
        return ["line_of_action.png", "transmission_error.png"]


class PlanarTCAStudy:
    """Problem 9.4.1 for one geometry and sweep (built once, ``run()`` for the report).

    Parameters
    ----------
    r_b1, r_b2, E : float
        Base radii and centre distance [mm].
    phi1 : (n,) array
        Rotations of gear 1 [rad].
    settings : gearopt.settings.PlanarTCASettings, optional
        ``method`` ({"continuation", "map"}), ``alpha_guess`` (pressure angle of the Newton starting
        point [rad]) and ``profiles`` (positions at which the profiles are sampled for the plot) as
        one object; keyword arguments replace its fields. Their defaults and ranges are declared
        there only.
    name : str
        Scene name.
    notes : list[str]
    """

    def __init__(self, r_b1: float, r_b2: float, E: float, phi1: ArrayLike, settings: PlanarTCASettings | None = None,
                 *, name: str = "planar_tca", notes: Sequence[str] = (), **options: Any) -> None:
        t0 = time.perf_counter()
        s = PlanarTCASettings.of(settings, **options)
        method, alpha_guess, profiles = s.method, s.alpha_guess, s.profiles
        self.settings = s
        self.tca = PlanarTCA(r_b1, r_b2, E)
        from ..errors import ArgumentError

        try:
            if np.asarray(phi1).dtype.kind in "USb":
                raise TypeError
            self.phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        except (TypeError, ValueError):
            raise ArgumentError(f"phi1 = {type(phi1).__name__} {str(phi1)[:60]!r}: expected a 1-D array of pinion "
                                "angles [rad] (numbers).",
                                param="phi1", value=phi1, valid="a 1-D array of pinion angles [rad] (numbers)") from None
        self.method, self.alpha_guess, self.n_profiles = method, alpha_guess, int(profiles)
        self.name, self.notes = name, list(notes)
        self.build_time = time.perf_counter() - t0

    def run(self, progress: Callable[[str], None] | None = None) -> PlanarTCAReport:
        t0 = time.perf_counter()
        if progress:
            progress(f"planar_tca: solving {self.phi1.size} positions ({self.method})")
        res = self.tca.solve(self.phi1, method=self.method, alpha_guess=self.alpha_guess, on_fail="raise")
        if progress:
            progress(f"planar_tca: {res.time_per_position_s * 1e3:.3f} ms per position, m12 = {res.m12:.12g}, "
                     f"max |TE| = {res.errors['te_max_abs']:.2e} rad")
        profiles = _sample_profiles(res, self.n_profiles)
        return PlanarTCAReport(scene=self.name, tca=res, profiles=profiles, notes=self.notes,
                               timing={"build_s": self.build_time, "run_s": time.perf_counter() - t0})


def _sample_profiles(res: PlanarTCAResult, k: int, m: int = 80) -> list:
    """Both profiles in S_f at ``k`` solved positions, from their base circle (theta = 0) to a bit
    beyond the largest solved theta."""
    if k <= 0:
        return []
    idx = np.unique(np.linspace(0, res.n - 1, k).round().astype(int))
    th1_max = 1.15 * float(np.max(res.theta1))
    th2_max = 1.15 * float(np.max(res.theta2))
    out = []
    for i in idx:
        p1 = profile_points(1, np.linspace(0, th1_max, m), float(res.phi1[i]), res.r_b1, res.r_b2, res.E)
        p2 = profile_points(2, np.linspace(0, th2_max, m), float(res.phi2[i]), res.r_b1, res.r_b2, res.E)
        out.append({"index": int(i), "phi1": float(res.phi1[i]), "phi2": float(res.phi2[i]),
                    "contact": res.r_f1[i].tolist(), "profile_1": p1.tolist(), "profile_2": p2.tolist()})
    return out


# --- scene binding ------------------------------------------------------------------------------
def _from_scene(scene) -> PlanarTCAStudy:
    o = scene.options.get("planar_tca", {}) or {}
    src = scene.source
    pair = scene.pair
    notes = []
    defaults = {"r_b1": pair.pinion.r_b, "r_b2": pair.gear.r_b, "E": pair.a_w}
    vals = {}
    for key, dflt in defaults.items():
        v = o.get(key)
        if v is None:
            vals[key] = dflt
            notes.append(f"{key} = {dflt:.9g} mm from the gear pair")
        else:
            vals[key] = v
            if abs(v - dflt) > 1e-9 * max(abs(dflt), 1.0):
                notes.append(f"[planar_tca] {key} = {v:.9g} mm differs from the pair's {dflt:.9g} mm; "
                             f"the [planar_tca] value is used")
    r_b1, r_b2, E = vals["r_b1"], vals["r_b2"], vals["E"]
    try:
        cf = closed_form(r_b1, r_b2, E)
    except GeometryError as e:  # r_b1, r_b2, E: the keys of [planar_tca] (the pair's values when not set)
        raise scene.study_error("planar_tca", e) from e
    lo, hi = cf["phi1_range"]
    span = hi - lo
    p_min = o.get("phi1_min")
    p_max = o.get("phi1_max")
    p_min = lo + 0.1 * span if p_min is None else p_min
    p_max = hi - 0.1 * span if p_max is None else p_max
    valid = (f"{lo / DEG:.6g} < phi1 < {hi / DEG:.6g} deg (contact between the base-circle tangency points "
             f"T1, T2 for r_b1 = {r_b1:g}, r_b2 = {r_b2:g}, E = {E:g} mm)")
    for key, v in (("phi1_min", p_min), ("phi1_max", p_max)):
        if not lo < v < hi:
            raise SceneError(f"{src}: [planar_tca] {key} = {v / DEG:.6g} deg is out of range; valid: {valid}.",
                             param=f"[planar_tca] {key}", value=f"{v / DEG:.6g} deg", valid=valid, source=src)
    if not p_min < p_max:
        raise SceneError(f"{src}: [planar_tca] phi1_min = {p_min / DEG:.6g} deg must be < phi1_max = "
                         f"{p_max / DEG:.6g} deg.",
                         param="[planar_tca] phi1_min", value=f"{p_min / DEG:.6g} deg", valid=f"< phi1_max = {p_max / DEG:.6g} deg",
                         source=src)
    phi1 = np.linspace(p_min, p_max, o.get("n") or 41)
    return PlanarTCAStudy(r_b1, r_b2, E, phi1, PlanarTCASettings.from_scene(o), name=scene.name, notes=notes)


def _register():
    from ..schema import Bounds, Field
    from . import StudySpec, register

    pos = Bounds(lo=0, lo_open=True)
    register(StudySpec(
        name="planar_tca",
        doc="TCA of two planar involute profiles (Litvin Problem 9.4.1): ratio, line of action, TE",
        sections=[PlanarTCASettings.section("planar_tca", [
            Field("r_b1", "length", check=pos, doc="base radius of gear 1 (driving); default the pinion's"),
            Field("r_b2", "length", check=pos, doc="base radius of gear 2 (driven); default the gear's"),
            Field("E", "length", check=pos, doc="centre distance, > r_b1 + r_b2; default the pair's a"),
            Field("phi1_min", "angle", doc="first rotation of gear 1; default: 10 % into T1 T2"),
            Field("phi1_max", "angle", doc="last rotation of gear 1; default: 90 % along T1 T2"),
            Field("n", "int", default=41, check=Bounds(lo=3, hi=100000), doc="number of positions"),
            "method", "alpha_guess", "profiles",
        ], required=False, doc="planar involute TCA (Problem 9.4.1)")],
        settings=(PlanarTCASettings,),
        build=_from_scene,
    ))


_register()
