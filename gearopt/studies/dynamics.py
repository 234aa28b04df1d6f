"""Gear dynamics study (docs/dynamics.md): the periodic steady state of the pair over a speed sweep,
driven by its loaded TCA at the operating torque (mesh stiffness and unloaded TE over the mesh
cycle); dynamic factor K_v, mesh-order response, resonance speeds against ISO 6336-1's n_E1,
contact loss and jumps.

Scene section ``[dynamics]``: ``torque`` (pinion torque [N m], required), the inertias
``inertia_pinion``, ``inertia_gear`` [kg m^2] (default the bodies' solid discs), optional
``inertia_drive`` / ``shaft_stiffness_drive`` and ``inertia_load`` / ``shaft_stiffness_load``
[kg m^2, N m/rad], ``E``, ``nu``, the misalignment (``dE``, ``crossing``, ``intersecting``, ``axial``;
default aligned), and the options of :class:`gearopt.dynamics.settings.DynamicsSettings`.

results.json keys: docs/results.md ("dynamics"); ``dynamics_speeds.csv`` (per case, branch and speed)
and ``dynamics_cycles.csv`` (dynamic mesh force and TE over the cycle at every speed) beside it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar

import numpy as np

from ..summary import KeyNumber, dynamics_summary
from ..units import RAD_TO_ARCSEC

if TYPE_CHECKING:  # pragma: no cover
    from ..dynamics.model import GearDynamics, PeriodicSolution, SpeedSweep
    from ..dynamics.settings import DynamicsSettings
    from ..gears import GearPair
    from ..ltca.compliance import Material
    from ..meshing.misalignment import Misalignment

UNITS = {"speed": "rpm (pinion)", "force": "N", "te": "arcsec (suffix _arcsec), um along the line of action (_um)",
         "stiffness": "N/um", "inertia": "kg m^2", "shaft_stiffness": "N m/rad", "frequency": "Hz", "phase": "rad",
         "K_v": "peak dynamic over static mesh force", "time": "s", "see": "docs/results.md"}
ORDERS = 5  #: mesh orders reported (1 ... ORDERS)
INERTIA_KEYS = ("inertia_pinion", "inertia_gear", "inertia_drive", "shaft_stiffness_drive", "inertia_load",
                "shaft_stiffness_load")


def _branch_dict(sols: list[PeriodicSolution], W: float, lever: float, backlash: float) -> dict:
    """Per speed: K_v, converged, contact loss, back-flank contact, mesh-order amplitudes of the
    dynamic TE [um] and force [N] (orders 1 ... ORDERS), TE peak-to-peak [um], and whether the branch's
    continuation jumped there (:meth:`GearDynamics.jump`)."""
    kv, conv, loss, back, amp, famp, pp, jumped = [], [], [], [], [], [], [], []
    for s in sols:
        conv.append(bool(s.converged))
        jumped.append(bool(s.jumped))
        if not s.converged:
            kv.append(None), loss.append(None), back.append(None), pp.append(None)
            amp.append([None] * ORDERS), famp.append([None] * ORDERS)
            continue
        kv.append(float(np.max(s.force) / W))
        loss.append(s.contact_loss()), back.append(s.back_flank(backlash))
        cx = np.fft.rfft(s.x) / len(s.x)
        cf = np.fft.rfft(s.force) / len(s.force)
        amp.append([float(2 * abs(cx[h]) * 1e6) for h in range(1, ORDERS + 1)])
        famp.append([float(2 * abs(cf[h])) for h in range(1, ORDERS + 1)])
        pp.append(float(np.ptp(s.x) * 1e6))
    return {"K_v": kv, "converged": conv, "contact_loss": loss, "back_flank": back, "order_te_um": amp,
            "order_force_N": famp, "te_peak_to_peak_um": pp, "jumped": jumped}


def _peaks(speeds: np.ndarray, kv: list) -> list[float]:
    """Speeds of the local maxima of K_v (converged neighbours; the sweep's ends excluded)."""
    out = []
    for i in range(1, len(kv) - 1):
        a, b, c = kv[i - 1], kv[i], kv[i + 1]
        if None not in (a, b, c) and b > a and b >= c:
            out.append(float(speeds[i]))
    return out


def _jumps(speeds: np.ndarray, up: list, down: list, rel: float = 1e-3) -> tuple[list[float], list[dict]]:
    """Speeds where the up and down branches differ (both converged; K_v apart by more than ``rel``)
    and the jumps at the ends of those ranges: the up branch leaves its range upward, the down
    branch downward."""
    co = [a is not None and b is not None and abs(a - b) > rel * max(a, b) for a, b in zip(up, down)]
    coexist = [float(v) for v, c in zip(speeds, co) if c]
    jumps = []
    for i in range(len(co) - 1):
        if co[i] and not co[i + 1] and up[i + 1] is not None:
            jumps.append({"branch": "up", "from_rpm": float(speeds[i]), "to_rpm": float(speeds[i + 1]),
                          "K_v_from": up[i], "K_v_to": up[i + 1]})
        if co[i + 1] and not co[i] and down[i] is not None:
            jumps.append({"branch": "down", "from_rpm": float(speeds[i + 1]), "to_rpm": float(speeds[i]),
                          "K_v_from": down[i + 1], "K_v_to": down[i]})
    return coexist, jumps


@dataclass
class DynamicsReport:
    """Result of :class:`DynamicsStudy` (``to_dict``: docs/results.md, "dynamics")."""

    scene: str
    pair: dict
    options: dict
    model: dict
    cases: list
    cycles: list = field(default_factory=list)  # per case: (speeds, phase, up solutions) for the CSV
    timing: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The results.json dictionary (docs/results.md, "dynamics study")."""
        return {"study": "dynamics", "scene": self.scene, "units": UNITS, "pair": self.pair, "options": self.options,
                "model": self.model, "cases": self.cases, "timing": self.timing}

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "dynamics_factor.png": "Dynamic factor K_v (peak dynamic over static mesh force) against pinion speed, sweeping "
                               "up and down, with contact loss marked and ISO 6336-1's n_E1 (top); per case the mesh-"
                               "order amplitudes of the dynamic TE (below): read the resonance speeds, how high K_v "
                               "rises there, where the teeth separate and which order dominates.",
        "dynamics_cycle.png": "Dynamic mesh force and dynamic TE over one mesh cycle at the lowest speed, at the K_v "
                              "peak and at the highest speed, beside the static loaded and unloaded TE: read how far "
                              "the dynamic response departs from the static one and where the force drops to zero.",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.dynamics_summary`), read from :meth:`to_dict`."""
        return dynamics_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``dynamics_factor.png`` (K_v against speed, both branches; mesh-order amplitudes) and
        ``dynamics_cycle.png`` (dynamic mesh force and TE over the cycle at the static limit, the
        K_v peak and the top speed)."""
        import matplotlib.pyplot as plt

        from ..plot.dynamics import plot_cycle_force, plot_cycle_te, plot_dynamic_factor, plot_order_amplitudes
        from ..plot.saving import drawn_here
        from ..plot.ticks import plain_ticks
        from .ltca import save_figure

        out = Path(out_dir)
        d = self.to_dict()
        n = len(d["cases"])
        # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
        files = ["dynamics_factor.png", "dynamics_cycle.png"]
        if drawn_here(out / "dynamics_factor.png"):
            fig = plt.figure(figsize=(14, 4.2 * (1 + n)), layout="constrained")
            gs = fig.add_gridspec(1 + n, 1)
            plot_dynamic_factor(d, ax=fig.add_subplot(gs[0]))
            for i in range(n):
                plot_order_amplitudes(d, i, ax=fig.add_subplot(gs[1 + i]))
            plain_ticks(*fig.axes)
            save_figure(out, self.scene, "dynamics_factor.png", fig,
                        "dynamic factor and mesh-order response against pinion speed", dpi)
        if drawn_here(out / "dynamics_cycle.png"):
            fig, axes = plt.subplots(n, 2, figsize=(14, 4.4 * n), layout="constrained", squeeze=False)
            for i in range(n):
                plot_cycle_force(d, i, ax=axes[i, 0])
                plot_cycle_te(d, i, ax=axes[i, 1])
            plain_ticks(*fig.axes)
            save_figure(out, self.scene, "dynamics_cycle.png", fig,
                        "dynamic mesh force and TE over the mesh cycle", dpi)
        return files

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """``dynamics_speeds.csv``: per case, branch and speed K_v, contact loss and the mesh-order
        amplitudes; ``dynamics_cycles.csv``: per case, speed (up branch) and phase the dynamic
        mesh force [N] and TE [um along the line of action]."""
        head = ["case", "branch", "speed_rpm", "converged", "K_v", "contact_loss", "back_flank", "te_pp_um"]
        head += [f"order{h}_te_um" for h in range(1, ORDERS + 1)] + [f"order{h}_force_N" for h in range(1, ORDERS + 1)]
        head += ["jumped"]
        rows = [",".join(head)]
        for c in self.cases:
            for br in ("up", "down"):
                b = c[br]
                for i, v in enumerate(c["speeds_rpm"]):
                    row = [c["name"], br, v, b["converged"][i], b["K_v"][i], b["contact_loss"][i], b["back_flank"][i],
                           b["te_peak_to_peak_um"][i], *b["order_te_um"][i], *b["order_force_N"][i], b["jumped"][i]]
                    rows.append(",".join(_cell(x) for x in row))
        (Path(out_dir) / "dynamics_speeds.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        rows = ["case,speed_rpm,phase_rad,force_N,te_um"]
        for name, sols in self.cycles:
            for s in sols:
                if not s.converged:
                    continue
                for ph, F, x in zip(s.phi, s.force, s.x):
                    rows.append(",".join(_cell(v) for v in (name, s.speed_rpm, ph, F, x * 1e6)))
        (Path(out_dir) / "dynamics_cycles.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        return ["dynamics_speeds.csv", "dynamics_cycles.csv"]


def _cell(v: Any) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, bool):
        return str(int(v))
    return f"{v:.10g}" if isinstance(v, float) else str(v)


class DynamicsStudy:
    """The dynamics study: one drive (and, with ``compare_unmodified``, the same drive without its
    modifications) at one torque over a speed sweep.

    Parameters
    ----------
    pair : GearPair
    torque : float
        Pinion torque [N m] (> 0, within the loaded TCA's range).
    settings : gearopt.dynamics.settings.DynamicsSettings, optional
        Keyword arguments replace its fields.
    material : Material, optional
    inertia_pinion, inertia_gear : float, optional
        Rotary inertias [kg m^2] (> 0; default the bodies' solid discs of ISO 6336-1).
    inertia_drive, shaft_stiffness_drive, inertia_load, shaft_stiffness_load : float, optional
        Drive and load inertias [kg m^2] with their shafts' torsional stiffness [N m/rad] (> 0, in pairs).
    misalignment : Misalignment, optional
        The drive's misalignment (default aligned): the loaded TCA's k(phi) and e(phi) follow it.
    name : str
    """

    def __init__(self, pair: GearPair, torque: float, settings: DynamicsSettings | None = None,
                 material: Material | None = None, inertia_pinion: float | None = None,
                 inertia_gear: float | None = None, inertia_drive: float | None = None,
                 shaft_stiffness_drive: float | None = None, inertia_load: float | None = None,
                 shaft_stiffness_load: float | None = None, misalignment: Misalignment | None = None,
                 name: str = "dynamics", **options: Any) -> None:
        from ..dynamics.drive import drive_train
        from ..dynamics.settings import DynamicsSettings
        from ..errors import OptionError, check_number, out_of_range
        from ..ltca.compliance import Material
        from ..ltca.engine import LTCA
        from ..ltca.validity import check_torque_range

        s = DynamicsSettings.of(settings, **options)
        torque = check_number("torque", torque, "the pinion torque [N m]", cls=OptionError)
        if not torque > 0:
            raise out_of_range("torque", torque, "torque > 0 N m (pinion torque)", cls=OptionError)
        self.material = material or Material()
        check_torque_range(pair, torque, self.material)
        LTCA(pair, s, material=self.material)  # the LTCA options, checked before any run
        self.pair, self.torque, self.settings, self.name = pair, float(torque), s, name
        from ..meshing.misalignment import Misalignment as Mis

        self.misalignment = misalignment or Mis()
        self.misalignment.check(pair, "misalignment")
        self.inertias = {"J_pinion": inertia_pinion, "J_gear": inertia_gear, "J_drive": inertia_drive,
                         "k_drive": shaft_stiffness_drive, "J_load": inertia_load, "k_load": shaft_stiffness_load}
        self.train = drive_train(pair, s.damping, s.backlash, **self.inertias)

    def _pairs(self) -> list[tuple[str, GearPair]]:
        out = [("as_given", self.pair)]
        if self.settings.compare_unmodified:
            p = self.pair
            from ..gears import GearPair

            out.append(("unmodified", GearPair(p.pinion.with_(modifications=None), p.gear.with_(modifications=None),
                                               a=p.a)))
        return out

    def run(self, progress: Callable[[str], None] | None = None) -> DynamicsReport:
        from ..dynamics.drive import iso_resonance_speed, loaded_mesh
        from ..dynamics.model import GearDynamics
        from ..ltca.compliance import iso6336_stiffness
        from ..units import DEG

        t0 = time.perf_counter()
        s, p, tr = self.settings, self.pair, self.train
        z1 = p.pinion.z
        cases, cycles, model = [], [], {}
        speeds = None
        for name, pair in self._pairs():
            if progress:
                progress(f"dynamics: loaded TCA of {name} at {self.torque:g} N m")
            lm = loaded_mesh(pair, self.torque, s, positions=s.positions, material=self.material,
                             misalignment=self.misalignment)
            gd = GearDynamics(tr, lm.excitation(s.harmonics), z1, smoothing=s.smoothing, samples=s.samples,
                              tol=1e-9, newton_tol=1e-7)
            fn = gd.natural_frequencies()
            if speeds is None:  # one speed grid for every case: from the first case's first resonance
                n_res = 60.0 * fn[0] / z1
                hi = s.speed_max if s.speed_max is not None else 1.5 * n_res
                lo = s.speed_min if s.speed_min is not None else 0.2 * n_res
                if lo >= hi:
                    lo = 0.0
                speeds = np.linspace(lo, hi, s.speeds) if lo > 0 else np.linspace(hi / s.speeds, hi, s.speeds)
                iso = iso6336_stiffness(p)
                b = min(p.pinion.b, p.gear.b)
                model = {"J_pinion_kg_m2": tr.J_pinion, "J_gear_kg_m2": tr.J_gear, "J_drive_kg_m2": tr.J_drive,
                         "k_drive_N_m_per_rad": tr.k_drive, "J_load_kg_m2": tr.J_load, "k_load_N_m_per_rad": tr.k_load,
                         "m_e_kg": tr.m_e, "coordinates": gd.names, "damping": tr.zeta, "backlash_um": tr.backlash * 1e6,
                         "c_gamma_iso_N_per_mm_um": iso["c_gamma_alpha"], "face_width_mm": b,
                         "n_E1_iso_rpm": iso_resonance_speed(p, tr, iso["c_gamma_alpha"])}
            if progress:
                progress(f"dynamics: {name}: sweep of {len(speeds)} speeds, up and down")
            sw: SpeedSweep = gd.sweep(speeds)
            cases.append(self._case(name, lm, gd, sw, fn))
            cycles.append((name, sw.up))
        timing = {"run_s": time.perf_counter() - t0}
        pair = {"z1": p.pinion.z, "z2": p.gear.z, "m_n": p.pinion.m_n, "beta_deg": p.pinion.beta / DEG,
                "b": min(p.pinion.b, p.gear.b), "r_b1": p.pinion.r_b, "r_b2": p.gear.r_b, "eps_alpha": p.eps_alpha,
                "eps_beta": p.eps_beta}
        options = {"torque_Nm": self.torque, "speed_min_rpm": float(speeds[0]), "speed_max_rpm": float(speeds[-1]),
                   "speeds": len(speeds), "damping": s.damping, "backlash_um": tr.backlash * 1e6,
                   "smoothing": s.smoothing, "harmonics": s.harmonics, "samples": s.samples, "positions": s.positions,
                   "n_slices": s.n_slices, "side": s.side, "compare_unmodified": s.compare_unmodified,
                   "E_MPa": self.material.E, "nu": self.material.nu,
                   "excitation": "k(phi) on the gap to the unloaded TE (form (a), docs/dynamics.md)"}
        from ..report import misalignment_dict

        model["misalignment"] = misalignment_dict(self.misalignment)
        return DynamicsReport(self.name, pair, options, model, cases, cycles, timing)

    def _case(self, name: str, lm: Any, gd: GearDynamics, sw: SpeedSweep, fn: np.ndarray) -> dict:
        from ..dynamics.drive import iso_resonance_speed

        z1 = self.pair.pinion.z
        W, lever, bl = lm.W, lm.lever_gear, self.train.backlash
        speeds = sw.speeds_rpm
        up, down = _branch_dict(sw.up, W, lever, bl), _branch_dict(sw.down, W, lever, bl)
        coexist, jumps = _jumps(speeds, up["K_v"], down["K_v"])
        kv_all = [(k, v, br) for br, b in (("up", up), ("down", down)) for k, v in zip(b["K_v"], speeds) if k is not None]
        kmax = max(kv_all) if kv_all else (None, None, None)
        loss = sorted({float(v) for b in (up, down) for v, c in zip(speeds, b["contact_loss"]) if c})
        back = sorted({float(v) for b in (up, down) for v, c in zip(speeds, b["back_flank"]) if c})
        failed = sorted({float(v) for b in (up, down) for v, c in zip(speeds, b["converged"]) if not c})
        jumped = sorted({float(v) for b in (up, down) for v, c in zip(speeds, b["jumped"]) if c})
        # the cycle at three speeds: the lowest, the K_v peak and the highest (up branch, where converged)
        picks = []
        for i in (0, int(np.nanargmax([k if k is not None else -1 for k in up["K_v"]])), len(speeds) - 1):
            sol = sw.up[i]
            if sol.converged and i not in [q[0] for q in picks]:
                picks.append((i, sol))
        cyc = {"speeds_rpm": [float(speeds[i]) for i, _ in picks], "phase": picks[0][1].phi.tolist() if picks else [],
               "force_N": [s.force.tolist() for _, s in picks],
               "te_dynamic_arcsec": [(-s.x / lever * RAD_TO_ARCSEC).tolist() for _, s in picks]}
        return {
            "name": name, "W_N": W, "torque_Nm": lm.torque,
            "static": {"phase": lm.phase.tolist(), "stiffness_N_per_um": lm.stiffness.tolist(),
                       "te_unloaded_arcsec": (lm.te_unloaded * RAD_TO_ARCSEC).tolist(),
                       "te_loaded_arcsec": (lm.te_loaded * RAD_TO_ARCSEC).tolist(),
                       "te_loaded_peak_to_peak_arcsec": float(np.ptp(lm.te_loaded) * RAD_TO_ARCSEC),
                       "stiffness_mean_N_per_um": float(np.mean(lm.stiffness)), "c_gamma_N_per_mm_um": lm.c_gamma,
                       "order_te_um": [float(2 * abs(a) * 1e6) for a in
                                       (np.fft.rfft(lm.te_loaded * lever) / len(lm.te_loaded))[1:ORDERS + 1]]},
            "natural_frequencies_Hz": fn.tolist(),
            "resonance_speeds_linear_rpm": {f"order{h}": [float(60 * f / (h * z1)) for f in fn]
                                            for h in range(1, ORDERS + 1)},
            "n_E1_ltca_rpm": iso_resonance_speed(self.pair, self.train, lm.c_gamma),
            "speeds_rpm": speeds.tolist(), "up": up, "down": down,
            "K_v_max": kmax[0], "K_v_max_speed_rpm": None if kmax[1] is None else float(kmax[1]),
            "K_v_max_branch": kmax[2],
            "resonance_speeds_rpm": {"up": _peaks(speeds, up["K_v"]), "down": _peaks(speeds, down["K_v"])},
            "contact_loss_speeds_rpm": loss, "back_flank_speeds_rpm": back, "coexisting_speeds_rpm": coexist,
            "jumps": jumps, "not_converged_speeds_rpm": failed, "jumped_speeds_rpm": jumped, "cycle": cyc,
            "sweep_time_s": sw.time_s,
        }


def _from_scene(scene: Any) -> DynamicsStudy:
    from ..dynamics.settings import DynamicsSettings
    from ..errors import GeometryError, OptionError
    from ..ltca.compliance import Material

    from .tca import check_misalignment_keys, misalignment_from

    o = scene.options.get("dynamics", {}) or {}
    check_misalignment_keys(scene, "dynamics", o, signs=(1,))
    try:
        return DynamicsStudy(scene.pair, o["torque"], settings=DynamicsSettings.from_scene(o),
                             material=Material(E=o["E"], nu=o["nu"]), name=scene.name,
                             misalignment=misalignment_from(o),
                             **{k: o.get(k) for k in INERTIA_KEYS})
    except (GeometryError, OptionError) as e:
        raise scene.study_error("dynamics", e) from e


def _register() -> None:
    from ..dynamics.settings import DynamicsSettings
    from ..schema import Bounds, Field
    from . import StudySpec, register
    from .ltca import material_fields
    from .tca import misalignment_fields

    inertia = [Field(k, "float", check=Bounds(lo=0, lo_open=True, hi=1e6),
                     doc=("torsional stiffness of the " + k.split("_")[-1] + " shaft [N*m/rad]") if k.startswith("shaft")
                     else (f"rotary inertia of the {k.split('_')[-1]} [kg*m^2]"
                           + (" (default the body's solid disc)" if k in ("inertia_pinion", "inertia_gear")
                              else " (with its shaft stiffness)")))
               for k in INERTIA_KEYS]
    register(StudySpec(
        name="dynamics",
        doc="Gear dynamics from the loaded TCA: dynamic factor, mesh-order response, resonances and contact "
            "loss over speed",
        sections=[DynamicsSettings.section("dynamics", [
            Field("torque", "float", required=True, check=Bounds(lo=0, lo_open=True, hi=1e7),
                  doc="pinion torque [N*m] (the loaded TCA's operating point)"),
            "speed_min", "speed_max", "speeds", "damping", "backlash", *inertia,
            "side", "positions", "n_slices", *material_fields(), "coupling", "compliance",
            "harmonics", "smoothing", "samples", "compare_unmodified",
            *misalignment_fields(),
        ], required=True)],
        settings=(DynamicsSettings,),
        build=_from_scene,
    ))


_register()
