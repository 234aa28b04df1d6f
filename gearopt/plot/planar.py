"""Plots of the planar involute TCA (Litvin & Fuentes, Problem 9.4.1, Fig. 9.4.5).

The functions only read a :class:`gearopt.studies.planar_tca.PlanarTCAReport` (its ``tca`` result
and sampled ``profiles``), take ``ax=`` and return the Axes.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..report import CONJUGATE_ARCSEC
from ..units import DEG, RAD_TO_ARCSEC
from .style import axes_or_new
from .ticks import plain_ticks

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from ..studies.planar_tca import PlanarTCAReport

__all__ = ["plot_line_of_action", "plot_transmission_error"]


def _circle(ax, c, r, **kw):
    t = np.linspace(0, 2 * math.pi, 361)
    return ax.plot(c[0] + r * np.cos(t), c[1] + r * np.sin(t), **kw)


def plot_line_of_action(report: PlanarTCAReport, ax: Axes | None = None, zoom: bool = False) -> Axes:
    """Base circles, centre line, line of action tangent to both base circles, contact points,
    pitch point I and both involute profiles at a few positions (Fig. 9.4.5).

    Parameters
    ----------
    report : PlanarTCAReport
    ax : matplotlib Axes, optional
    zoom : bool
        Limit the view to the meshing zone (segment T1 T2 and a margin) instead of both gears.

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax)
    t = report.tca
    rb1, rb2, E = t.r_b1, t.r_b2, t.E
    O1, O2 = np.array([0.0, 0.0]), np.array([0.0, E])
    ok = t.ok
    # base circles and the pitch (operating) circles through I, from the solved y_I
    _circle(ax, O1, rb1, color="C0", lw=1.4, label=f"base circles r_b1 = {rb1:.4g}, r_b2 = {rb2:.4g} mm")
    _circle(ax, O2, rb2, color="C0", lw=1.4)
    if math.isfinite(t.y_I):
        _circle(ax, O1, t.y_I, color="0.55", lw=0.8, ls="--",
                label=f"operating pitch circles r_w1 = {t.y_I:.4g}, r_w2 = {E - t.y_I:.4g} mm")
        _circle(ax, O2, E - t.y_I, color="0.55", lw=0.8, ls="--")
    # centre line
    ax.plot([0, 0], [-rb1 * 1.15, E + rb2 * 1.15], color="k", lw=0.8, ls="-.")
    ax.plot(*O1, "k+", ms=10)
    ax.plot(*O2, "k+", ms=10)
    ax.annotate("$O_1$", O1, xytext=(6, -12), textcoords="offset points")
    ax.annotate("$O_2$", O2, xytext=(6, 4), textcoords="offset points")
    # line of action fitted through the solved contact points, drawn from T1 to T2 and a bit beyond
    if t.T1 is not None:
        T1, T2, d = np.asarray(t.T1), np.asarray(t.T2), np.asarray(t.loa_direction)
        ext = 0.12 * np.linalg.norm(T2 - T1)
        a, b = T1 - ext * np.sign((T2 - T1) @ d) * d, T2 + ext * np.sign((T2 - T1) @ d) * d
        alpha = math.acos(max(-1.0, min(1.0, t.cos_loa)))
        ax.plot([a[0], b[0]], [a[1], b[1]], color="C3", lw=1.3,
                label=f"line of action (fitted), alpha_w = {alpha / DEG:.4f} deg")
        for P, O, name in ((T1, O1, "$T_1$"), (T2, O2, "$T_2$")):
            ax.plot([O[0], P[0]], [O[1], P[1]], color="C0", lw=0.7, ls=":")
            ax.plot(*P, "o", color="C0", ms=4)
            ax.annotate(name, P, xytext=(6, -4), textcoords="offset points")
        if math.isfinite(t.y_I):
            # the label "I" right beside its point (below the line of action, left of the centre line)
            ax.plot(0, t.y_I, "D", color="k", ms=5, zorder=5)
            ax.annotate("I", (0, t.y_I), xytext=(-5, -5), textcoords="offset points", ha="right", va="top",
                        fontsize=10, fontweight="bold")
    # profiles at a few positions
    for k, p in enumerate(report.profiles):
        p1, p2 = np.asarray(p["profile_1"]), np.asarray(p["profile_2"])
        lab1 = "profile 1 (gear 1, driving)" if k == 0 else None
        lab2 = "profile 2 (gear 2, driven)" if k == 0 else None
        ax.plot(p1[:, 0], p1[:, 1], color="C2", lw=1.1, alpha=0.85, label=lab1)
        ax.plot(p2[:, 0], p2[:, 1], color="C4", lw=1.1, alpha=0.85, label=lab2)
        if zoom:
            ax.plot(*p["contact"], "o", mfc="none", color="k", ms=7)
            ax.annotate(f"$\\phi_1$ = {p['phi1'] / DEG:.1f} deg", p["contact"], xytext=(10, 10),
                        textcoords="offset points", fontsize=8, color="0.2")
    ax.plot(t.r_f1[ok, 0], t.r_f1[ok, 1], ".", color="C1", ms=4, label=f"solved contact points ({int(ok.sum())})")
    if (~ok).any():
        ax.plot(t.r_f1[~ok, 0], t.r_f1[~ok, 1], "x", color="r", ms=6, label="rejected points")
    ax.set_aspect("equal")
    if zoom and t.T1 is not None:
        T1, T2 = np.asarray(t.T1), np.asarray(t.T2)
        c, h = 0.5 * (T1 + T2), 0.5 * np.max(np.abs(T2 - T1)) * 1.3
        ax.set_xlim(c[0] - h, c[0] + h)
        ax.set_ylim(c[1] - h, c[1] + h)
    ax.set_xlabel("$x_f$ [mm]")
    ax.set_ylabel("$y_f$ [mm]")
    if zoom:
        ax.set_title(f"meshing zone: contact points on the line of action T$_1$T$_2$\n"
                     f"pitch point I at $y_I$ = {t.y_I:.4f} mm", fontsize=10)
    else:
        ax.set_title(f"{report.scene}: line of action (Litvin Fig. 9.4.5)\nE = {E:.6g} mm, "
                     f"m12 = {t.m12:.9g}, $y_I$ = {t.y_I:.6g} mm", fontsize=10)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, frameon=False)
    ax.grid(True, lw=0.3)
    plain_ticks(ax)
    return ax


def plot_transmission_error(report: PlanarTCAReport, ax: Axes | None = None) -> Axes:
    """Transmission error [arcsec] of the solved positions against phi1 [deg] (zero for involutes
    at any centre distance: what remains is round-off).

    Parameters
    ----------
    report : PlanarTCAReport
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
    """
    ax = axes_or_new(ax)
    t = report.tca
    ok = t.ok
    te = np.asarray(t.te) * RAD_TO_ARCSEC
    peak = float(np.max(np.abs(te[ok]))) if ok.any() else 0.0
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("$\\phi_1$ [deg]")
    ax.set_ylabel("TE [arcsec] (+: gear 2 ahead)")
    if peak < CONJUGATE_ARCSEC:  # involutes are conjugate at any centre distance: what remains is round-off
        ax.plot(t.phi1[ok] / DEG, np.zeros(int(ok.sum())), "o-", color="C3", ms=3, lw=1.5,
                label=f"conjugate: TE = 0 at the {int(ok.sum())} solved positions")
        ax.set_ylim(-1.0, 1.0)
        ax.text(0.5, 0.7, f"conjugate: TE = 0\n(computed max |TE| {peak:.1g} arcsec: round-off)",
                transform=ax.transAxes, ha="center", va="center", fontsize=9, bbox=dict(fc="white", ec="0.6"))
        ax.set_title(f"{report.scene}: transmission error, conjugate (TE = 0), m12 = {t.m12:.12g}", fontsize=9)
    else:
        ax.plot(t.phi1[ok] / DEG, te[ok], "o-", color="C3", ms=3, lw=1, label="TE = phi2 - phi1 r_b1/r_b2 - const")
        ax.set_ylim(-peak * 1.5, peak * 1.5)
        ax.set_title(f"{report.scene}: transmission error (max |TE| = {peak:.3g} arcsec), m12 = {t.m12:.12g}",
                     fontsize=9)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    plain_ticks(ax)
    return ax
