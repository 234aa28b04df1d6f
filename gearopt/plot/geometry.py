"""Plots of gear geometry. They only read a report (``GeometryReport`` or its ``to_dict()``),
take ``ax=`` and return the Axes."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..geometry.frames import rot_z_points
from .style import axes_or_new
from .ticks import plain_ticks

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def _data(report) -> dict:
    return report if isinstance(report, dict) else report.to_dict()


_rot = rot_z_points  # points (n, 2) about the centre (gearopt.geometry.frames)


def tooth_outline(prof: dict) -> np.ndarray:
    """Closed outline of one tooth from root to root: left fillet, left flank, tip, right flank,
    right fillet (transverse section) [mm], shape (k, 2)."""
    P = {k: np.asarray(v) for k, v in prof.items()}
    return np.vstack([P["left_fillet"][::-1], P["left_flank"][::-1], P["tip"][::-1], P["right_flank"],
                      P["right_fillet"]])


def gear_outline(prof: dict, z: int, r_root: float, teeth: int | None = None) -> np.ndarray:
    """Outline of a whole gear (or of the teeth indices in ``teeth``) with root arcs [mm]."""
    one = tooth_outline(prof)
    pitch = 2 * math.pi / z
    idx = sorted(range(z) if teeth is None else teeth, reverse=True)
    pts = []
    for k in idx:  # tooth k is turned counter-clockwise by k pitches; walk clockwise
        t = _rot(one, k * pitch)
        pts.append(t)
        if teeth is None or (k - 1) in idx:  # root arc to the next tooth clockwise
            a0 = math.atan2(t[-1, 1], t[-1, 0])
            nxt = _rot(one[:1], (k - 1) * pitch)[0]
            a1 = math.atan2(nxt[1], nxt[0])
            if a1 > a0:
                a1 -= 2 * math.pi
            ang = np.linspace(a0, a1, 8)
            pts.append(r_root * np.c_[np.cos(ang), np.sin(ang)])
    return np.vstack(pts)


def _circle(ax, r, center=(0.0, 0.0), **kw):
    t = np.linspace(0, 2 * math.pi, 721)
    ax.plot(center[0] + r * np.cos(t), center[1] + r * np.sin(t), **kw)


def plot_tooth(report: dict, member: str = "pinion", ax: Axes | None = None) -> Axes:
    """One tooth of ``member`` with its fillets and the base, form, pitch, root and tip circles.

    Parameters
    ----------
    report : GeometryReport or dict
    member : {"pinion", "gear"}
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax)
    d = _data(report)
    m, prof = d["members"][member], d["profiles"][member]
    P = {k: np.asarray(v) for k, v in prof.items()}
    pitch = 2 * math.pi / m["z"]
    for k in (-1, 1):  # neighbour teeth, faint
        o = _rot(tooth_outline(prof), k * pitch)
        ax.plot(o[:, 0], o[:, 1], color="0.75", lw=0.8)
    ax.plot(P["right_flank"][:, 0], P["right_flank"][:, 1], color="C0", lw=2, label="involute flank")
    ax.plot(P["left_flank"][:, 0], P["left_flank"][:, 1], color="C0", lw=2)
    ax.plot(P["right_fillet"][:, 0], P["right_fillet"][:, 1], color="C3", lw=2, label="fillet (trochoid offset)")
    ax.plot(P["left_fillet"][:, 0], P["left_fillet"][:, 1], color="C3", lw=2)
    ax.plot(P["tip"][:, 0], P["tip"][:, 1], color="k", lw=1.5)
    circles = [("r_a", "tip", "k", "-"), ("r_p", "pitch", "C2", "-."), ("r_b", "base", "C1", "--"),
               ("r_form", "form", "C4", ":"), ("r_f", "root", "0.4", "-")]
    ylo = m["r_f"] - 0.8 * m["m_n"]
    half = 1.3 * pitch * m["r_a"] / 2 + 0.5 * m["m_n"]
    for key, label, col, ls in circles:
        r = m[key]
        t = np.linspace(math.pi / 2 - 1.4 * pitch, math.pi / 2 + 1.4 * pitch, 200)
        ax.plot(r * np.cos(t), r * np.sin(t), color=col, ls=ls, lw=0.9, label=f"{label} r = {r:.3f} mm")
    ax.set_xlim(-half, half)
    ax.set_ylim(ylo, m["r_a"] + 0.6 * m["m_n"])
    ax.set_aspect("equal")
    flag = "  UNDERCUT" if m["undercut"] else ""
    if m.get("folded") and not m["undercut"]:  # folded by profile crowning (issue 10)
        flag = f"  FOLDED (a_c > {m['a_c_max_unfolded']:.3g} 1/mm)"
    ax.set_title(f"{member}: z = {m['z']}, m_n = {m['m_n']:g} mm, x = {m['x']:+.3f}, "
                 f"alpha_n = {m['alpha_n_deg']:.1f} deg{flag}\n{m['generation']}-generated, "
                 f"s_a = {m['s_a']:.3f} mm, undercut margin dx = {m['undercut_margin_x']:+.3f}", fontsize=9)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
    ax.grid(alpha=0.3)
    plain_ticks(ax)
    return ax


def plot_pair_mesh(report: dict, ax: Axes | None = None, teeth: int = 4) -> Axes:
    """Pinion (centre at the origin) and gear (centre at (0, a)) in mesh at the pitch point, with
    the line of action, tip and base circles and the path of contact A-E."""
    ax = axes_or_new(ax)
    d = _data(report)
    pr, mp, mg = d["pair"], d["members"]["pinion"], d["members"]["gear"]
    a, aw = pr["a"], math.radians(pr["alpha_wt_deg"])
    span = lambda m: range(-teeth, teeth + 1)  # noqa: E731
    op = gear_outline(d["profiles"]["pinion"], mp["z"], mp["r_f"], teeth=span(mp))
    ax.plot(op[:, 0], op[:, 1], color="C0", lw=1.3, label="pinion")
    og = gear_outline(d["profiles"]["gear"], mg["z"], mg["r_f"], teeth=span(mg))
    og = _rot(og, math.pi + math.pi / mg["z"]) + np.array([0.0, a])  # a space of the gear faces the pinion tooth
    ax.plot(og[:, 0], og[:, 1], color="C1", lw=1.3, label="gear")
    r_w1 = a * mp["z"] / (mp["z"] + mg["z"])
    I = np.array([0.0, r_w1])
    # line of action tangent to both base circles, through I
    T1 = mp["r_b"] * np.array([-math.sin(aw), math.cos(aw)])
    T2 = np.array([0.0, a]) + mg["r_b"] * np.array([math.sin(aw), -math.cos(aw)])
    ax.plot([T1[0], T2[0]], [T1[1], T2[1]], "k--", lw=0.8, label="line of action")
    u = (T2 - T1) / np.linalg.norm(T2 - T1)
    g1 = math.sqrt(max(mp["r_a"] ** 2 - mp["r_b"] ** 2, 0))
    g2 = math.sqrt(max(mg["r_a"] ** 2 - mg["r_b"] ** 2, 0))
    A = T2 - g2 * u  # gear tip meets the line of action (start of contact, pinion driving)
    E = T1 + g1 * u
    ax.plot([A[0], E[0]], [A[1], E[1]], color="C3", lw=3, label=f"path of contact g_a = {pr['path_of_contact']:.3f} mm")
    ax.plot(*I, "ko", ms=4)
    ax.annotate("I", I, textcoords="offset points", xytext=(6, -10))
    for P_, lab in ((A, "A"), (E, "E")):
        ax.plot(*P_, "o", color="C3", ms=4)
        ax.annotate(lab, P_, textcoords="offset points", xytext=(5, 4))
    for m, c in ((mp, (0.0, 0.0)), (mg, (0.0, a))):
        _circle(ax, m["r_b"], c, color="0.5", ls="--", lw=0.6)
        _circle(ax, m["r_a"], c, color="0.5", ls=":", lw=0.6)
    w = max(5 * mp["m_n"], 1.6 * pr["path_of_contact"]) + 2 * mp["m_n"]
    ax.set_xlim(-w, w)
    ax.set_ylim(r_w1 - 0.8 * w, r_w1 + 0.8 * w)
    ax.set_aspect("equal")
    scene = f"{d['scene']}: " if d.get("scene") else ""
    ax.set_title(f"{scene}pair in mesh (transverse section)\na = {a:.4f} mm, alpha_wt = {pr['alpha_wt_deg']:.3f} deg, "
                 f"eps_alpha = {pr['eps_alpha']:.3f}, eps_beta = {pr['eps_beta']:.3f}", fontsize=10)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(alpha=0.3)
    plain_ticks(ax)
    return ax


def plot_rack_mesh(report: dict, member: str = "pinion", ax: Axes | None = None, teeth: int = 3) -> Axes:
    """The rack-cutter in mesh with the generated gear (Litvin Fig. 10.3.2): the tool outline,
    pitch line and circle, base circle and the lines of action through the pitch point I."""
    ax = axes_or_new(ax)
    d = _data(report)
    m, rk = d["members"][member], d["rack_cutter"][member]
    og = gear_outline(d["profiles"][member], m["z"], m["r_f"], teeth=range(-teeth, teeth + 1))
    ax.plot(og[:, 0], og[:, 1], color="C0", lw=1.4, label=f"{member} (transverse section)")
    out = np.asarray(rk["outline"])
    ax.fill_between(out[:, 0], out[:, 1], out[:, 1].max() + m["m_n"], color="C1", alpha=0.25, lw=0)
    ax.plot(out[:, 0], out[:, 1], color="C1", lw=1.4, label="rack-cutter")
    r_p, r_b, at = rk["r_p"], rk["r_b"], rk["alpha_t"]
    I = np.array([0.0, r_p])
    half = 2.2 * math.pi * m["m_t"]
    ax.axhline(r_p, color="C2", ls="-.", lw=0.8, label="rack centrode (pitch line)")
    if abs(rk["datum_line_y"] - r_p) > 1e-9:
        ax.axhline(rk["datum_line_y"], color="C4", ls=":", lw=0.8, label=f"datum line (x_E m_n = {rk['datum_line_y'] - r_p:+.3f} mm"
                   + (", thickness allowance" if m.get("A_sne") else "") + ")")
    for sgn in (1, -1):  # lines of action through I, tangent to the base circle at T
        T = np.array([sgn * r_b * math.sin(at), r_b * math.cos(at)])
        E = I + 0.6 * (I - T)
        ax.plot([T[0], E[0]], [T[1], E[1]], "k--", lw=0.7, label="line of action" if sgn > 0 else None)
    t = np.linspace(math.pi / 2 - 0.9 * half / r_p, math.pi / 2 + 0.9 * half / r_p, 200)
    ax.plot(r_p * np.cos(t), r_p * np.sin(t), color="C2", lw=0.8, ls="-.")
    ax.plot(r_b * np.cos(t), r_b * np.sin(t), color="C1", lw=0.8, ls="--", label="base circle")
    ax.plot(*I, "ko", ms=4)
    ax.annotate("I", I, textcoords="offset points", xytext=(5, 5))
    ax.set_xlim(-half, half)
    ax.set_ylim(m["r_f"] - 2.0 * m["m_n"], r_p + 2.6 * m["m_n"])
    ax.set_aspect("equal")
    ax.set_title(f"{member}: rack-cutter in mesh (alpha_t = {math.degrees(at):.2f} deg)", fontsize=9)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(alpha=0.3)
    plain_ticks(ax)
    return ax
