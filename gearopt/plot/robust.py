"""Plots of the robust-design studies (Monte Carlo, design sweeps): histograms and CDFs of TE
peak-to-peak and harmonics, scatter against inputs, ranked sensitivities, and the probability map
of the contact pattern on the pinion flank. Each takes ``ax=`` and returns the Axes; they only read
the result (``RobustResult`` pieces as a dict)."""

from __future__ import annotations

import numpy as np

from ..units import RAD_TO_ARCSEC

LABELS = {"te_p2p": "TE peak-to-peak [arcsec]", "h1": "1st mesh harmonic of TE [arcsec]",
          "loaded_te_p2p": "loaded TE peak-to-peak [arcsec]", "p_max": "peak Hertz pressure, flank [MPa]"}
NOMINAL = {"loaded_te_p2p": "loaded_te_p2p_arcsec", "p_max": "p_max_MPa"}  #: key of the nominal value


def _values(d: dict, key: str) -> np.ndarray:
    f = d["figures"]
    if key == "p_max":
        return np.asarray(f["p_max"], float)
    if key in ("te_p2p", "loaded_te_p2p"):
        return f[key] * RAD_TO_ARCSEC
    return f["harmonics"][:, int(key[1:]) - 1] * RAD_TO_ARCSEC


def _ax(ax):
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    return ax


def plot_histogram(d: dict, key: str = "te_p2p", ax=None, bins: int | None = None):
    """Histogram of ``key`` ("te_p2p", "h1", ...) over the samples, samples with edge contact
    stacked in their own colour; the 50 / 95 % percentiles and the nominal drive marked."""
    ax = _ax(ax)
    v = _values(d, key)
    edge = d["figures"]["edge_contact"]
    fin = np.isfinite(v)
    if not fin.any():
        ax.text(0.5, 0.5, "no sample with a defined value", ha="center", transform=ax.transAxes)
        return ax
    bins = bins or int(min(40, max(8, fin.sum() // 5)))
    ax.hist([v[fin & ~edge], v[fin & edge]], bins=bins, stacked=True, color=["tab:blue", "tab:red"],
            label=[f"surface contact ({int((fin & ~edge).sum())})", f"edge contact ({int((fin & edge).sum())})"])
    for q, ls in ((50, "--"), (95, ":")):
        x = np.percentile(v[fin], q)
        ax.axvline(x, color="k", ls=ls, lw=1, label=f"{q} %: {x:.3g}")
    nom = d.get("nominal", {}).get(NOMINAL.get(key, f"{key}_arcsec"))
    if nom is not None:
        ax.axvline(nom, color="tab:green", lw=1.5, label=f"nominal: {nom:.3g}")
    ax.set_xlabel(LABELS.get(key, key))
    ax.set_ylabel("samples")
    ax.legend(fontsize=8)
    return ax


def plot_cdf(d: dict, key: str = "te_p2p", ax=None):
    """Empirical CDF of ``key`` over the samples whose value is defined."""
    ax = _ax(ax)
    v = np.sort(_values(d, key)[np.isfinite(_values(d, key))])
    if v.size:
        ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", color="tab:blue")
        for q in (0.5, 0.95):
            ax.axhline(q, color="0.7", lw=0.8)
    ax.set_xlabel(LABELS.get(key, key))
    ax.set_ylabel("share of samples <= value")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    return ax


def plot_scatter(d: dict, name: str, key: str = "te_p2p", ax=None):
    """``key`` against the input ``name`` (its display unit), edge-contact samples in red."""
    from ..robust.study import display
    ax = _ax(ax)
    x, unit = display(name, d["inputs"][name])
    y = _values(d, key)
    edge = d["figures"]["edge_contact"]
    ax.scatter(x[~edge], y[~edge], s=4, alpha=0.5, color="tab:blue", label="surface contact", rasterized=True)
    if edge.any():
        ax.scatter(x[edge], y[edge], s=6, alpha=0.7, color="tab:red", label="edge contact", rasterized=True)
    ax.set_xlabel(f"{name} [{unit}]")
    ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4))
    ax.set_ylabel(LABELS.get(key, key))
    ax.legend(fontsize=7, markerscale=2)
    ax.grid(alpha=0.3)
    return ax


def plot_sensitivity(d: dict, key: str = "te_p2p", ax=None):
    """Ranked influence of the inputs on ``key``: Spearman rank correlation with the input
    (monotonic effect) and with its distance from the median (even effect), as bars."""
    ax = _ax(ax)
    rows = d["sensitivities"].get(key, [])
    names = [r["input"] for r in rows][::-1]
    y = np.arange(len(names))
    ax.barh(y + 0.2, [r["spearman"] for r in rows][::-1], height=0.4, color="tab:blue",
            label="Spearman rho with the input")
    ax.barh(y - 0.2, [r["spearman_abs"] for r in rows][::-1], height=0.4, color="tab:orange",
            label="Spearman rho with |input - median|")
    ax.set_yticks(y, names)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlim(-1.05, 1.05)
    ax.set_xlabel(f"correlation with {LABELS.get(key, key)}")
    ax.legend(fontsize=8, loc="lower right")
    return ax


def plot_pattern_probability(d: dict, ax=None):
    """Probability of each point of the pinion flank (face position x radius) being in the contact
    pattern (the major axes of the contact ellipses of every pair over the mesh cycle), with the
    face ends, the tip and the form circle, and the nominal drive's pattern outline."""
    ax = _ax(ax)
    gz, gr = np.asarray(d["grid_z"]), np.asarray(d["grid_r"])
    prob = np.asarray(d["pattern_count"], float) / max(d["n"], 1)
    m = ax.pcolormesh(gz, gr, np.where(prob > 0, prob, np.nan), cmap="viridis", vmin=0, vmax=1, shading="flat")
    ax.figure.colorbar(m, ax=ax, label="probability of contact")
    lim = d["limits"]
    b, r_a, r_f = lim["b"], lim["r_a"], lim["r_form"]
    ax.plot([-b / 2, b / 2, b / 2, -b / 2, -b / 2], [r_f, r_f, r_a, r_a, r_f], color="k", lw=1.2,
            label="active flank (face, form circle, tip)")
    nom = d.get("nominal") or {}
    zz, rr = nom.get("pattern_z_mm"), nom.get("pattern_radius_mm")
    if zz and rr and None not in zz and None not in rr:
        ax.plot([zz[0], zz[1], zz[1], zz[0], zz[0]], [rr[0], rr[0], rr[1], rr[1], rr[0]], color="tab:red", ls="--",
                lw=1.2, label="nominal pattern extent")
    ax.set_xlabel("face position z [mm]")
    ax.set_ylabel("radius on the pinion [mm]")
    pad = 0.04 * b
    ax.set_xlim(-b / 2 - pad, b / 2 + pad)
    ax.set_ylim(r_f - 0.05 * (r_a - r_f), r_a + 0.05 * (r_a - r_f))
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    return ax
