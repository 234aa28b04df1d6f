"""Loaded tooth contact analysis study (docs/ltca.md): loaded TE over the mesh cycle and against
torque, load sharing, mesh stiffness, line load across the face and the loaded contact pattern.

Scene section ``[ltca]``:

``torque``      nominal pinion torque [N m] (required).
``torques``     pinion torques analysed [N m], an increasing array (default: 10, 25, 50, 75, 100,
                125 and 150 % of ``torque``); the maps of the contact pattern are drawn at ``torque``.
``side``        driving flank of the pinion ("right", default, or "left").
``positions``   positions per mesh cycle (default 64; one cycle is analysed).
                (``side``, ``positions``, ``n_slices``, ``coupling``, ``compliance``: declared once, with their
                defaults and ranges, by :class:`gearopt.settings.LTCAStudySettings`.)
``n_slices``    slices across the face (default 21; the face ends are slices too).
``E``, ``nu``   Young's modulus [MPa] and Poisson's ratio (206000, 0.3).
``coupling``    coupling length of the teeth's compliance across the face [mm] (default half the pinion tooth
                height); each body's term couples over its own depth r_f - r_int (docs/ltca.md section 2).
``r_int_pinion``, ``r_int_gear``: inner radii of the gear bodies [mm] (default half the root radius).
``compliance``  "analytical" (default) or "fe" (CalculiX influence coefficients, cached on disk).
``dE``, ``crossing``, ``intersecting``, ``axial``: the misalignment of the drive (default aligned).

results.json keys: docs/results.md; ``ltca_positions.csv`` (per torque and position) and
``ltca_te_vs_torque.csv`` beside it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from typing import Any, Callable, ClassVar, Sequence, TYPE_CHECKING

import numpy as np

from ..units import DEG
from ..summary import KeyNumber, ltca_summary

if TYPE_CHECKING:  # pragma: no cover
    from ..gears import GearPair
    from ..ltca.compliance import Material
    from ..meshing.misalignment import Misalignment
    from ..settings import LTCAStudySettings
    from matplotlib.figure import Figure

UNITS = {"length": "mm", "angle": "rad", "phi1": "rad", "torque": "N m", "force": "N", "pressure": "MPa",
         "te": "arcsec (suffix _arcsec); positive: the gear ahead of its conjugate position",
         "stiffness": "N/um (mesh), N/(mm um) (per unit face width, c_gamma)", "time": "s",
         "see": "docs/results.md"}

#: default torque list as shares of the nominal torque
DEFAULT_SHARES = (0.10, 0.25, 0.50, 0.75, 1.00, 1.25, 1.50)


@dataclass
class LTCAReport:
    scene: str
    pair: dict
    options: dict
    misalignment: dict
    data: dict
    limits: dict
    iso6336: dict
    timing: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        out = {"study": "ltca", "scene": self.scene, "units": UNITS, "pair": self.pair, "options": self.options,
               "misalignment": self.misalignment, "limits": self.limits, "iso6336": self.iso6336}
        out.update(self.data)
        out["timing"] = self.timing
        return out

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "ltca_te.png": "Loaded TE over one mesh cycle at every torque (top), its peak-to-peak and first harmonic "
                       "against torque (bottom left) and its mesh harmonics (bottom right): read how the TE grows "
                       "with load and at which torque it is smallest.",
        "ltca_sharing.png": "Load share of the tooth pairs over the mesh cycle, mesh stiffness per torque against "
                            "ISO 6336-1's c_gamma, and the load across the face at the position of peak pressure: "
                            "read where one pair carries the whole load and how evenly the face is loaded.",
        "ltca_pattern.png": "Loaded contact pattern on the pinion and gear flanks at the nominal torque, coloured by "
                            "the largest Hertz pressure over the mesh cycle; crosses mark a loaded tip edge: read "
                            "whether the pattern stays inside the flank and off the tip (edge loading).",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.ltca_summary`), read from :meth:`to_dict`."""
        return ltca_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``ltca_te.png`` (loaded TE at every torque; TE against torque; harmonics),
        ``ltca_sharing.png`` (load sharing, mesh stiffness, load across the face) and
        ``ltca_pattern.png`` (loaded contact pattern on both flanks at the nominal torque)."""
        import matplotlib.pyplot as plt

        from ..plot.ltca import (plot_contact_pattern, plot_face_load, plot_harmonics, plot_load_sharing,
                                 plot_loaded_te, plot_mesh_stiffness, plot_te_vs_torque)
        from ..plot.saving import drawn_here
        from ..plot.tca import misalignment_text
        from ..plot.ticks import plain_ticks

        out = Path(out_dir)
        d = self.to_dict()

        mis = misalignment_text({"misalignment": d["misalignment"]}) or "aligned"

        def save(name, fig, title):
            plain_ticks(*fig.axes)
            return save_figure(out, self.scene, name, fig, f"{title} ({mis})", dpi)

        # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
        files = ["ltca_te.png", "ltca_sharing.png", "ltca_pattern.png"]
        if drawn_here(out / "ltca_te.png"):
            fig = plt.figure(figsize=(13, 8), layout="constrained")
            gs = fig.add_gridspec(2, 2)
            plot_loaded_te(d, ax=fig.add_subplot(gs[0, :]))
            plot_te_vs_torque(d, ax=fig.add_subplot(gs[1, 0]))
            plot_harmonics(d, ax=fig.add_subplot(gs[1, 1]))
            save("ltca_te.png", fig, "loaded transmission error")
        # two columns (three in a row shrank the text below reading size on a page or a screen): load
        # sharing and mesh stiffness above, the load and pressure across the face below
        if drawn_here(out / "ltca_sharing.png"):
            fig = plt.figure(figsize=(13, 10), layout="constrained")
            gs = fig.add_gridspec(4, 2, height_ratios=(1, 1, 0.8, 0.8))
            plot_load_sharing(d, ax=fig.add_subplot(gs[:2, 0]))
            plot_mesh_stiffness(d, ax=fig.add_subplot(gs[:2, 1]))
            ax_q = fig.add_subplot(gs[2, :])
            plot_face_load(d, ax=ax_q, ax_pressure=fig.add_subplot(gs[3, :], sharex=ax_q))
            ax_q.set_xlabel("")
            save("ltca_sharing.png", fig, "load sharing, mesh stiffness, load across the face")
        if drawn_here(out / "ltca_pattern.png"):
            fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), layout="constrained")
            pat = d["pattern"]
            p_flank = np.where(np.array(pat.get("edge", [0] * len(pat["p0_MPa"]))) > 0, 0.0,
                               np.array(pat["p0_MPa"], float))  # one scale for both flanks; tip edges are marked
            vmax = max(float(np.nanmax(p_flank)), 1.0) if p_flank.size else 1.0
            plot_contact_pattern(d, "pinion", ax=axes[0], vmax=vmax)
            plot_contact_pattern(d, "gear", ax=axes[1], vmax=vmax)
            save("ltca_pattern.png", fig, "loaded contact pattern, largest pressure over the mesh cycle")
        return files

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """``ltca_positions.csv``: per torque and position the loaded and unloaded TE, mesh
        stiffness, peak flank pressure, the tip edges' load share and every pair's load share; ``ltca_te_vs_torque.csv``."""
        d = self.to_dict()
        pairs = d["pairs"]
        head = (["torque_Nm", "phi1_deg", "te_unloaded_arcsec", "te_loaded_arcsec", "stiffness_N_per_um",
                 "p_max_MPa", "edge_share"] + [f"share_pair_{k}" for k in pairs])
        lines = [",".join(head)]
        for t in d["torques"]:
            for i, phi in enumerate(d["phi1"]):
                row = [t["torque_Nm"], math.degrees(phi), d["te_unloaded_arcsec"][i], t["te_loaded_arcsec"][i],
                       t["stiffness_N_per_um"][i], t["p_max_per_position_MPa"][i], t["edge_share"][i]]
                row += [t["pair_share"][k][i] for k in range(len(pairs))]
                lines.append(",".join(_cell(v) for v in row))
        (Path(out_dir) / "ltca_positions.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
        c = d["te_vs_torque"]
        rows = ["torque_Nm,peak_to_peak_arcsec,harmonic1_arcsec,p_max_MPa,c_gamma_N_per_mm_um"]
        for t, pp, h1, tt in zip(c["torque_Nm"], c["peak_to_peak_arcsec"], c["harmonic1_arcsec"], d["torques"]):
            rows.append(",".join(_cell(v) for v in (t, pp, h1, tt["p_max_MPa"], tt["c_gamma_N_per_mm_um"])))
        (Path(out_dir) / "ltca_te_vs_torque.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        return ["ltca_positions.csv", "ltca_te_vs_torque.csv"]


def _cell(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return f"{v:.10g}" if isinstance(v, float) else str(v)


class LTCAStudy:
    """The ltca study: one drive, one misalignment case, a list of torques.

    Parameters
    ----------
    pair : GearPair
    torque : float
        Nominal pinion torque [N m] (> 0): the contact pattern and load-across-face maps are drawn there.
    torques : sequence of float, optional
        Torques analysed [N m], strictly increasing (default: 10 ... 150 % of ``torque``).
    misalignment : Misalignment, optional
    name : str
    settings : gearopt.settings.LTCAStudySettings, optional
        ``positions`` (per mesh cycle) and the options of :class:`~gearopt.ltca.engine.LTCA` (``side``,
        ``n_slices``, ``coupling``, ``compliance``...); keyword arguments replace its fields.
    material : Material, optional
    r_int : (float, float), optional
        As :class:`~gearopt.ltca.engine.LTCA`.
    """

    def __init__(self, pair: GearPair, torque: float, torques: Sequence[float] | None = None,
                 misalignment: Misalignment | None = None, name: str = "ltca",
                 settings: LTCAStudySettings | None = None, material: Material | None = None,
                 r_int: tuple[float, float] | None = None, **options: Any) -> None:
        from ..errors import OptionError, check_number, out_of_range
        from ..ltca.engine import LTCA
        from ..ltca.validity import check_torque_range
        from ..meshing.misalignment import Misalignment
        from ..settings import LTCAStudySettings

        s = LTCAStudySettings.of(settings, **options)
        torque = check_number("torque", torque, "the nominal pinion torque [N m]", cls=OptionError)
        if not torque > 0:
            raise out_of_range("torque", torque, "torque > 0 N m (nominal pinion torque)", cls=OptionError)
        if torques is None:
            torques = [s * torque for s in DEFAULT_SHARES]
        self.pair, self.torque, self.torques, self.positions, self.name = pair, torque, list(torques), s.positions, name
        self.settings = s
        self.misalignment = misalignment or Misalignment()
        self.misalignment.check(pair, "misalignment")
        self.ltca = LTCA(pair, s, material=material, r_int=r_int)
        self.ltca.validate_torques(self.torques)
        check_torque_range(pair, max(self.torques), self.ltca.material)

    def limits(self) -> dict:
        t = self.ltca.tca
        return {"pinion": {"b": self.pair.pinion.b, "r_a": self.pair.pinion.r_a, "r_form": t.form_radius(1)},
                "gear": {"b": self.pair.gear.b, "r_a": self.pair.gear.r_a, "r_form": t.form_radius(2)}}

    def run(self, progress: Callable[[str], None] | None = None) -> LTCAReport:
        from ..ltca.compliance import iso6336_stiffness
        from ..report import misalignment_dict

        t0 = time.perf_counter()
        L = self.ltca
        p = self.pair
        phi = L.mesh_cycle(self.positions)
        if progress:
            progress(f"ltca: unloaded separations ({self.positions} positions x {len(L.default_pairs())} pairs x "
                     f"{L.n_slices} slices)")
        S = L.slices(phi, mis=self.misalignment)
        if progress:
            progress(f"ltca: {len(self.torques)} torques, {min(self.torques):.4g} ... {max(self.torques):.4g} N m")
        # one call: the contact structure once, each torque's contact set started from the previous one's
        sweep = L.solve(self.torques, slices=S)
        results = sweep.results
        from ..ltca.contact_qp import QP_METHOD
        data = sweep.to_dict(p.pinion.z, nominal=self.torque)
        pair = {"z1": p.pinion.z, "z2": p.gear.z, "m_n": p.pinion.m_n, "beta_deg": p.pinion.beta / DEG, "a": p.a_w,
                "b": min(p.pinion.b, p.gear.b), "b1": p.pinion.b, "b2": p.gear.b, "r_b1": p.pinion.r_b,
                "r_b2": p.gear.r_b, "eps_alpha": p.eps_alpha, "eps_beta": p.eps_beta,
                "pinion_a_c": p.pinion.rack.a_c, "pinion_a_pl": p.pinion.a_pl, "side": L.side}
        m = L.material
        options = {"E_MPa": m.E, "nu": m.nu, "n_slices": L.n_slices, "positions": self.positions,
                   "coupling_mm": L.coupling_length, "body_coupling_mm": list(L.body_coupling), "r_int_mm": list(L.r_int), "compliance": L.compliance,
                   "qp_solver": QP_METHOD, "torques_Nm": self.torques}
        iso = iso6336_stiffness(p)
        nom = min(data["torques"], key=lambda r: abs(r["torque_Nm"] - self.torque))
        iso["ltca_c_gamma_at_nominal"] = nom["c_gamma_N_per_mm_um"]
        iso["ltca_over_iso"] = nom["c_gamma_N_per_mm_um"] / iso["c_gamma_alpha"]
        timing = {"run_s": time.perf_counter() - t0, "separations_s": S.stats.get("time_s"),
                  "solve_s": float(sum(r.solve_time for r in results))}
        return LTCAReport(scene=self.name, pair=pair, options=options, misalignment=misalignment_dict(self.misalignment),
                          data=data, limits=self.limits(), iso6336=iso, timing=timing)


def _from_scene(scene) -> LTCAStudy:
    from ..errors import GeometryError, OptionError
    from ..ltca.compliance import H_FI_RANGE, Material
    from ..settings import LTCAStudySettings
    from .tca import check_misalignment_keys, misalignment_from

    o = scene.options.get("ltca", {}) or {}
    check_misalignment_keys(scene, "ltca", o, signs=(1,))
    torque = o["torque"]
    torques = o.get("torques")
    if torques is not None:
        bad = [v for v in torques if not v > 0]
        if bad:
            raise scene.key_error("ltca", "torques", f"is out of range; valid: every torque > 0 N m (got {bad[0]:g}).",
                                  valid="every torque > 0 N m")
        if any(b <= a for a, b in zip(torques, torques[1:])):
            raise scene.key_error("ltca", "torques", "is out of range; valid: a strictly increasing list of pinion "
                                  "torques [N m] (the TE-against-torque curve).", valid="strictly increasing torques")
    g1, g2 = scene.pair.pinion, scene.pair.gear
    r_int = (o.get("r_int_pinion") or 0.5 * g1.r_f, o.get("r_int_gear") or 0.5 * g2.r_f)
    for key, v, g in (("r_int_pinion", r_int[0], g1), ("r_int_gear", r_int[1], g2)):
        lo, hi = g.r_f / H_FI_RANGE[1], g.r_f / H_FI_RANGE[0]
        if not lo <= v <= hi:
            valid = (f"{lo:.4g} mm <= {key} <= {hi:.4g} mm (the bore of the body: {H_FI_RANGE[0]} <= r_f / r_int <= "
                     f"{H_FI_RANGE[1]} with r_f = {g.r_f:.6g} mm, the range of Sainsot's body term)")
            raise scene.key_error("ltca", key, f"is out of range; valid: {valid}.", valid=valid)
    try:
        return LTCAStudy(scene.pair, torque, torques=torques, misalignment=misalignment_from(o), name=scene.name,
                         settings=LTCAStudySettings.from_scene(o), material=Material(E=o["E"], nu=o["nu"]),
                         r_int=r_int)
    except (GeometryError, OptionError) as e:
        raise scene.study_error("ltca", e) from e


def check_torques(v: list[float]) -> str | None:
    """Scene check of a torque list: every torque > 0, strictly increasing (None when fine)."""
    if any(not t > 0 for t in v):
        return "every torque > 0 N m"
    if any(b <= a for a, b in zip(v, v[1:])):
        return "a strictly increasing list of pinion torques [N m]"
    return None


def torque_fields(nominal: str, listed: str) -> list:
    """Scene keys ``torque`` (the nominal pinion torque, required) and ``torques`` (an increasing list);
    ``nominal`` and ``listed`` complete their one-line docs."""
    from ..io.schema import Bounds, Field

    return [Field("torque", "float", required=True, check=Bounds(lo=0, lo_open=True, hi=1e7),
                  doc=f"nominal pinion torque [N*m] ({nominal})"),
            Field("torques", "floats", check=check_torques, doc=f"{listed} [N*m], increasing")]


def material_fields() -> list:
    """Scene keys of the elastic constants of both members (``E`` [MPa], ``nu``)."""
    from ..schema import Bounds, Field
    from ..settings import check_modulus

    return [Field("E", "float", default=206000.0, check=check_modulus, doc="Young's modulus [MPa]"),
            Field("nu", "float", default=0.3, check=Bounds(lo=0, lo_open=True, hi=0.5, hi_open=True),
                  doc="Poisson's ratio")]


def save_figure(out: Path, scene: str, name: str, fig: Figure, title: str, dpi: int) -> str:
    """Title ``fig`` with the scene, write it as ``out/name`` and close it; returns ``name``."""
    import matplotlib.pyplot as plt

    fig.suptitle(f"{scene}: {title}")
    fig.savefig(out / name, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return name


def _register():
    from ..schema import Bounds, Field
    from ..settings import LTCAStudySettings
    from . import StudySpec, register
    from .tca import misalignment_fields

    register(StudySpec(
        name="ltca",
        doc="Loaded TCA: loaded TE over the mesh cycle and against torque, load sharing, mesh stiffness, "
            "contact pressure and pattern",
        sections=[LTCAStudySettings.section("ltca", [
            *torque_fields("contact pattern drawn there", "pinion torques analysed (default 10 ... 150 % of torque)"),
            "side", "positions", "n_slices",
            *material_fields(),
            "coupling",
            Field("r_int_pinion", "length", check=Bounds(lo=0, lo_open=True, hi=1e5),
                  doc="inner radius of the pinion body (default half its root radius)"),
            Field("r_int_gear", "length", check=Bounds(lo=0, lo_open=True, hi=1e5),
                  doc="inner radius of the gear body (default half its root radius)"),
            "compliance",
            *misalignment_fields(),
        ], required=True)],
        settings=(LTCAStudySettings,),
        build=_from_scene,
    ))


_register()
