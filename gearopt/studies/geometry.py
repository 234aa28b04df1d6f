"""Geometry report of a gear pair: radii, contact ratio, undercut and form margins, tooth profiles.

Each member is cut by its own tool (``[pinion] tool = {kind = ...}``, default its rack-cutter; see
:mod:`gearopt.geometry.tools`), as in every other study. Scene section ``[geometry]`` (all optional):

``points``      samples per profile segment in the results and plots (default 60, 10..2000).
``rack_mesh``   draw the rack-cutter in mesh with each member (default true; rack/hob-cut members).

The former keys ``generation``, ``N_h``, ``d_p0``, ``N_s``, ``x_s`` (one tool for both members) are
refused with the ``tool = {...}`` text to write instead.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar
from pathlib import Path

import numpy as np

from ..gears import Gear, GearPair
from ..geometry.generation import GeneratedTooth, Hob, Shaper, default_params, generate, rack_profile_functions
from ..geometry.tools import RackCutter
from ..settings import GeometryStudySettings
from ..summary import KeyNumber, geometry_summary
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

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "profiles.png": "Transverse tooth profiles of pinion and gear with the tip, pitch, base, form and root "
                        "circles: read the tip thickness, the fillet (red) and whether the involute reaches down to "
                        "the form circle (no undercut).",
        "pair_mesh.png": "The pair in mesh with the line of action and the path of contact A-E: read the length of "
                         "contact (contact ratio) and the tip clearances.",
        "rack_mesh.png": "Each member with its generating rack-cutter (Litvin Fig. 10.3.2): read the profile shift "
                         "(datum line against the pitch line) and how the rack cuts the fillet.",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.geometry_summary`), read from :meth:`to_dict`."""
        return geometry_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """Write ``profiles.png``, ``pair_mesh.png`` and ``rack_mesh.png`` into ``out_dir``."""
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

        fig, ax = plt.subplots(figsize=(10.5, 7.5))
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
        Each member is generated by its own tool (``Gear.tool``).
    generation : {"rack", "hob", "shaper"}, optional
        Shorthand that replaces both members' tools by one (the former interface); default None:
        each member's own tool.
    hob, shaper : Hob, Shaper, optional
        Tool data when ``generation`` names them.
    settings : gearopt.settings.GeometryStudySettings, optional
        ``points`` (samples per profile segment) and ``rack_mesh`` (include the rack-cutter outline
        for the rack-in-mesh plot) as one object; keyword arguments replace its fields. Their
        defaults and ranges are declared there only.
    name : str
        Scene name used in titles.
    """

    def __init__(self, pair: GearPair, generation: str | None = None, hob: Hob | None = None,
                 shaper: Shaper | None = None, settings: GeometryStudySettings | None = None, *,
                 name: str = "geometry", **options: Any) -> None:
        t0 = time.perf_counter()
        s = GeometryStudySettings.of(settings, **options)
        points, rack_mesh = s.points, s.rack_mesh
        self.settings = s
        if generation is not None:
            tools = {"rack": RackCutter(), "hob": hob or Hob(), "shaper": shaper or Shaper()}
            if generation not in tools:
                from ..errors import out_of_range
                raise out_of_range("generation", generation, "'rack', 'hob', 'shaper' or None (each member's tool)")
            t = tools[generation]
            pair = GearPair(pair.pinion.with_(tool=t), pair.gear.with_(tool=t), pair.a)
        self.pair, self.points, self.rack_mesh, self.name = pair, points, rack_mesh, name
        self.teeth: dict[str, GeneratedTooth] = {"pinion": generate(pair.pinion), "gear": generate(pair.gear)}
        self.generation = {k: t.method for k, t in self.teeth.items()}
        self.build_time = time.perf_counter() - t0

    def run(self, progress: Callable[[str], None] | None = None) -> GeometryReport:
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
            # the real end of the flank (junction, or crossing below a fold), whatever the tool
            lim = tooth.flank_limit("right", 0.0)
            r_form = float(lim.radius)
            fold = {"flank_limit": lim.kind, "folded": lim.folded}
            if lim.folded and g.tool.rack_settings:  # a_c is the rack-cutter's / hob's setting
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
                "generation": tooth.method, "tool": {k: v for k, v in tooth.extras.items() if k not in ("q_pitch", "q_above_tip")},
                "r_p": g.r_p, "r_b": g.r_b, "r_a": g.r_a, "r_f": tooth.r_root, "r_form": r_form,
                "r_active_start": r_start,
                "form_margin": r_start - r_form,
                "s_t": g.s_t, "s_a": g.s_at(g.r_a), "s_a_over_m_n": g.s_at(g.r_a) / g.m_n,
                "undercut": g.undercut, "x_min_undercut": g.x_min_undercut, "z_min_undercut": g.z_min_undercut,
                "undercut_margin_x": g.x_E - g.x_min_undercut, "x_max_pointed": g.x_max_pointed,
                "flank_u_form": u_f, **fold,
            }
            profiles[name] = {k: v.tolist() for k, v in prof.items()}
            if self.rack_mesh and g.tool.rack_settings:  # the tool cuts with the basic rack's profile
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
    from ..errors import GeometryError, OptionError

    o = scene.options.get("geometry", {}) or {}
    try:
        return GeometryStudy(scene.pair, settings=GeometryStudySettings.from_scene(o), name=scene.name)
    except (GeometryError, OptionError) as e:
        raise scene.study_error("geometry", e) from e


_OLD_TOOL_KEYS = ("generation", "N_h", "d_p0", "N_s", "x_s")


def _moved_tool_hint(table: dict) -> str:
    """What to write instead of the former ``[geometry]`` tool keys (the same tool for both members)."""
    from ..schema import toml_text

    gen = table.get("generation", "rack")
    if gen == "hob":
        keys = {"z": table.get("N_h"), "d_p0": table.get("d_p0")}
    elif gen == "shaper":
        keys = {"z": table.get("N_s"), "x": table.get("x_s")}
    else:
        keys = {}
    body = ", ".join([f"kind = {toml_text(gen)}"] + [f"{k} = {toml_text(v)}" for k, v in keys.items() if v is not None])
    tail = (" (the rack-cutter is the default: simply remove these keys)" if gen == "rack" else "")
    return (f"the cutting tool is no longer a [geometry] key but a key of each gear, used by every study: write "
            f"tool = {{{body}}} under [pinion] and under [gear]{tail}, and remove {', '.join(_OLD_TOOL_KEYS)} from "
            "[geometry] (see `gearopt studies`).")


def _register():
    from ..schema import Section
    from . import StudySpec, register

    register(StudySpec(
        name="geometry",
        doc="Gear pair geometry report: radii, contact ratio, undercut/form margins, tooth profiles and plots",
        sections=[Section("geometry", GeometryStudySettings.scene_fields(), required=False,
                          doc="the tools are [pinion] tool / [gear] tool", moved=_OLD_TOOL_KEYS,
                          moved_hint=_moved_tool_hint)],
        settings=(GeometryStudySettings,),
        build=_from_scene,
    ))


_register()
