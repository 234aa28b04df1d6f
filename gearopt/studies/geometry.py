"""Geometry report of a gear pair: radii, contact ratio, undercut and form margins, tooth profiles.

Scene section ``[geometry]`` (all optional):

``generation``  "rack" (default), "hob" or "shaper": the tool that generates both members.
``N_h``         hob threads (hob only; default 1).   ``d_p0`` hob reference diameter (mm; 60).
``N_s``         shaper teeth (shaper only; default 25).   ``x_s`` shaper profile shift (0).
``points``      samples per profile segment in the results and plots (default 60, 10..2000).
``rack_mesh``   draw the rack-cutter in mesh with each member (default true).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..gears import Gear, GearPair
from ..geometry.generation import (GeneratedTooth, Hob, Shaper, default_params, generate_by_hob,
                                   generate_by_rack, generate_by_shaper, rack_profile_functions)
from ..units import DEG

UNITS = {"length": "mm (suffix _um: micrometres)", "angle": "rad (suffix _deg: degrees)", "ratio": "-", "time": "s",
         "backlash": "mm; backlash_circumferential on the working pitch circles (j_wt), backlash_normal along the "
                     "flank normal (j_bn); without suffix: smallest (upper allowances A_sne), _max: largest (A_sni)",
         "profiles": "mm, transverse section at mid face (z = 0), gear frame, tooth centred on +y"}


def _active_start(a, alpha_w, r_b, r_b_mate, r_a_mate):
    """Radius on a member where contact with the mating tip begins (start of active profile)."""
    g = a * math.sin(alpha_w) - math.sqrt(max(r_a_mate**2 - r_b_mate**2, 0.0))
    return math.hypot(r_b, g), g


@dataclass(frozen=True)
class GeometryReport:
    """Result of the geometry study: every number of the report and the sampled profiles.

    ``to_dict()`` is what ``results.json`` holds; the plots read only this object.
    """

    scene: str
    members: dict
    pair: dict
    profiles: dict = field(repr=False)
    rack: dict = field(repr=False)
    timing: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"study": "geometry", "scene": self.scene, "units": UNITS, "pair": self.pair,
                "members": self.members, "profiles": self.profiles, "rack_cutter": self.rack,
                "timing": self.timing}

    def save_plots(self, out_dir, dpi: int = 120) -> list[str]:
        """Write ``profiles.png``, ``pair_mesh.png`` and ``rack_mesh.png`` into ``out_dir``."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from pathlib import Path

        from ..plot.geometry import plot_pair_mesh, plot_rack_mesh, plot_tooth

        out = Path(out_dir)
        files = []
        fig, axes = plt.subplots(1, 2, figsize=(11, 5.5))
        for ax, name in zip(axes, ("pinion", "gear")):
            plot_tooth(self, name, ax=ax)
        fig.suptitle(f"{self.scene}: tooth profiles (transverse section)")
        fig.tight_layout()
        fig.savefig(out / "profiles.png", dpi=dpi, bbox_inches="tight")
        plt.close(fig)
        files.append("profiles.png")

        fig, ax = plt.subplots(figsize=(8, 7))
        plot_pair_mesh(self, ax=ax)
        fig.tight_layout()
        fig.savefig(out / "pair_mesh.png", dpi=dpi, bbox_inches="tight")
        plt.close(fig)
        files.append("pair_mesh.png")

        if self.rack:
            fig, axes = plt.subplots(len(self.rack), 1, figsize=(10, 4.2 * len(self.rack)), squeeze=False)
            for ax, name in zip(axes[:, 0], self.rack):
                plot_rack_mesh(self, name, ax=ax)
            fig.suptitle(f"{self.scene}: rack-cutter in mesh (Litvin Fig. 10.3.2)")
            fig.tight_layout()
            fig.savefig(out / "rack_mesh.png", dpi=dpi, bbox_inches="tight")
            plt.close(fig)
            files.append("rack_mesh.png")
        return files


class GeometryStudy:
    """Compiled geometry study of a pair (build once, ``run()`` for the report).

    Parameters
    ----------
    pair : GearPair
    generation : {"rack", "hob", "shaper"}
    hob, shaper : Hob, Shaper, optional
        Tool data when ``generation`` names them.
    points : int
        Samples per profile segment.
    rack_mesh : bool
        Include the rack-cutter outline for the rack-in-mesh plot.
    name : str
        Scene name used in titles.
    """

    def __init__(self, pair: GearPair, generation: str = "rack", hob: Hob | None = None,
                 shaper: Shaper | None = None, points: int = 60, rack_mesh: bool = True, name: str = "geometry"):
        t0 = time.perf_counter()
        self.pair, self.points, self.rack_mesh, self.name = pair, points, rack_mesh, name
        self.generation = generation
        gen = {"rack": lambda g: generate_by_rack(g), "hob": lambda g: generate_by_hob(g, hob),
               "shaper": lambda g: generate_by_shaper(g, shaper)}[generation]
        self.teeth: dict[str, GeneratedTooth] = {"pinion": gen(pair.pinion), "gear": gen(pair.gear)}
        self.build_time = time.perf_counter() - t0

    def run(self, progress=None) -> GeometryReport:
        t0 = time.perf_counter()
        pair = self.pair
        a, aw = pair.a_w, pair.alpha_wt
        members, profiles, racks = {}, {}, {}
        mates = {"pinion": pair.gear, "gear": pair.pinion}
        for name, tooth in self.teeth.items():
            if progress:
                progress(f"geometry: {name} profile")
            g: Gear = tooth.gear
            mate = mates[name]
            prof = tooth.transverse_profile(0.0, self.points)
            u_f, _ = tooth.junction()
            r_form = float(np.hypot(*prof["right_flank"][-1]))
            fold = {}
            if tooth.method in ("rack", "hob"):  # the real end of the flank (junction, or crossing below a fold)
                lim = tooth.flank_limit("right", 0.0)
                r_form = float(lim.radius)
                fold = {"flank_limit": lim.kind, "folded": lim.folded}
                if lim.folded:
                    fold["a_c_max_unfolded"] = float(tooth.max_unfolded_a_c("right", 0.0))
            r_start, _ = _active_start(a, aw, g.r_b, mate.r_b, mate.r_a)
            members[name] = {
                "z": g.z, "m_n": g.m_n, "m_t": g.m_t, "x": g.x, "k": g.k, "b": g.b,
                "A_sne": g.A_sne, "A_sni": g.A_sni, "x_E": g.x_E, "d_a": 2 * g.r_a,
                "beta_deg": g.beta / DEG, "hand": g.hand if not g.is_spur else None,
                "alpha_n_deg": g.rack.alpha_n / DEG, "alpha_t_deg": g.alpha_t / DEG, "beta_b_deg": g.beta_b / DEG,
                "rack": {"name": g.rack.name, "h_aP": g.rack.h_aP, "h_fP": g.rack.h_fP, "rho_fP": g.rack.rho_fP,
                         "a_c": g.rack.a_c, "u_0": g.rack.u_0},
                "a_pl": g.a_pl,
                "generation": tooth.method, "tool": {k: v for k, v in tooth.extras.items() if k != "q_pitch"},
                "r_p": g.r_p, "r_b": g.r_b, "r_a": g.r_a, "r_f": tooth.r_root, "r_form": r_form,
                "r_active_start": r_start,
                "form_margin": r_start - r_form,
                "s_t": g.s_t, "s_a": g.s_at(g.r_a), "s_a_over_m_n": g.s_at(g.r_a) / g.m_n,
                "undercut": g.undercut, "x_min_undercut": g.x_min_undercut, "z_min_undercut": g.z_min_undercut,
                "undercut_margin_x": g.x_E - g.x_min_undercut, "x_max_pointed": g.x_max_pointed,
                "flank_u_form": u_f, **fold,
            }
            profiles[name] = {k: v.tolist() for k, v in prof.items()}
            if self.rack_mesh and tooth.method in ("rack", "hob"):
                racks[name] = _rack_outline(g)
        r_A1, g1 = _active_start(a, aw, pair.pinion.r_b, pair.gear.r_b, pair.gear.r_a)
        r_A2, g2 = _active_start(a, aw, pair.gear.r_b, pair.pinion.r_b, pair.pinion.r_a)
        path = a * math.sin(aw) - g1 - g2  # length of the path of contact on the line of action
        c1, c2 = pair.tip_clearance
        j_bn = pair.backlash_normal
        report_pair = {
            "ratio": pair.ratio, "a": a, "a_0": pair.a_0, "a_minus_a_0_um": pair.a_minus_a_0 * 1000,
            "a_0_tolerance_um": pair.a_0_tolerance * 1000,
            "alpha_wt_deg": aw / DEG,
            "backlash_circumferential": pair.backlash, "backlash_circumferential_max": pair.backlash_max,
            "backlash_normal": j_bn[0], "backlash_normal_max": j_bn[1],
            "tip_clearance_pinion": c1, "tip_clearance_gear": c2,
            "eps_alpha": pair.eps_alpha, "eps_beta": pair.eps_beta, "eps_gamma": pair.eps_gamma,
            "g_alpha": pair.g_alpha, "path_of_contact": path, "base_pitch_t": pair.pinion.p_bt,
            "involute_interference": any(members[n]["form_margin"] < 0 for n in members),
        }
        return GeometryReport(scene=self.name, members=members, pair=report_pair, profiles=profiles, rack=racks,
                              timing={"build_s": self.build_time, "run_s": time.perf_counter() - t0})


def _rack_outline(g: Gear, teeth: int = 3) -> dict:
    """Transverse outline of the rack-cutter (several tool teeth) at psi = 0, in the gear frame [mm]."""
    prof = rack_profile_functions(g.rack, g.m_n)
    p = default_params(g)
    u_f, phi_max, _ = (np.asarray(v).ravel() for v in prof["junction"](p))
    h_top = -(g.rack.h_aP + 0.35) * g.m_n  # draw the tool body up to a bit beyond its root line
    u_top = h_top / math.cos(g.rack.alpha_n)
    us = np.linspace(u_top, float(u_f[0]), 40)
    fl = np.array([np.asarray(prof["flank"](u, p)[0]).ravel() for u in us])
    ph = np.linspace(0.0, float(phi_max[0]), 20)
    fi = np.array([np.asarray(prof["fillet"](t, p)[0]).ravel() for t in ph])
    right = np.vstack([fl, fi])  # tool flank cutting the tooth's right side, datum frame (xi, eta)
    left = right[::-1] * np.array([-1.0, 1.0])
    p_n = math.pi * g.m_n
    # One tool tooth: the left side of the next tooth to the right is the mirror of 'right' about xi = p_n/2.
    tooth = np.vstack([right, (left + np.array([p_n, 0.0]))])
    cb = math.cos(g.beta)
    pts = []
    for k in range(-teeth, teeth):
        seg = tooth + np.array([k * p_n, 0.0])
        pts.append(seg)
    out = np.vstack(pts)
    out[:, 0] /= cb  # transverse section of the rack
    out[:, 1] += g.r_p + g.x_E * g.m_n
    return {"outline": out.tolist(), "pitch_line_y": g.r_p, "datum_line_y": g.r_p + g.x_E * g.m_n,
            "alpha_t": g.alpha_t, "r_p": g.r_p, "r_b": g.r_b}


# --- scene binding ------------------------------------------------------------------------------
def _from_scene(scene) -> GeometryStudy:
    from ..errors import GeometryError, OptionError, SceneError

    o = scene.options.get("geometry", {}) or {}
    gen = o.get("generation") or "rack"
    tool_keys = {"hob": ("N_h", "d_p0"), "shaper": ("N_s", "x_s")}
    for tool, keys in tool_keys.items():
        for k in keys:
            if o.get(k) is not None and gen != tool:
                raise SceneError(f"{scene.source}: [geometry] {k} applies only with generation = \"{tool}\" "
                                 f"(generation is \"{gen}\"); remove it or change generation.",
                                 param=f"[geometry] {k}", value=scene.written("geometry", k), valid=f"only with generation = \"{tool}\"")
    try:
        hob = Hob(N_h=o.get("N_h") or 1, d_p0=o.get("d_p0") or 60.0) if gen == "hob" else None
        shaper = Shaper(N_s=o.get("N_s") or 25, x_s=o.get("x_s") or 0.0) if gen == "shaper" else None
        return GeometryStudy(scene.pair, generation=gen, hob=hob, shaper=shaper, points=o.get("points") or 60,
                             rack_mesh=o.get("rack_mesh", True) is not False, name=scene.name)
    except (GeometryError, OptionError) as e:
        raise scene.study_error("geometry", e, prefixes=("hob", "shaper")) from e


def _register():
    from ..io.schema import Bounds, Field, Section
    from . import StudySpec, register

    register(StudySpec(
        name="geometry",
        doc="Gear pair geometry report: radii, contact ratio, undercut/form margins, tooth profiles and plots",
        sections=[Section("geometry", [
            Field("generation", "str", default="rack", choices=("rack", "hob", "shaper"),
                  doc="tool that generates both members"),
            Field("N_h", "int", check=Bounds(lo=1, hi=8), doc="hob threads (generation = hob)"),
            Field("d_p0", "length", check=Bounds(lo=0, lo_open=True), doc="hob reference diameter (generation = hob)"),
            Field("N_s", "int", check=Bounds(lo=8, hi=400), doc="shaper teeth (generation = shaper)"),
            Field("x_s", "float", check=Bounds(lo=-1, hi=2), doc="shaper profile shift (generation = shaper)"),
            Field("points", "int", default=60, check=Bounds(lo=10, hi=2000), doc="samples per profile segment"),
            Field("rack_mesh", "bool", default=True, doc="plot the rack-cutter in mesh (rack/hob generation)"),
        ], required=False)],
        build=_from_scene,
    ))


_register()
