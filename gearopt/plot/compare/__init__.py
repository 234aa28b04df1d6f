"""Plots that put several designs of the same gear pair side by side (``gearopt compare``).

Every function reads designs as a mapping ``label -> results`` (the dictionaries of their
``results.json``, in the order given on the command line), takes ``ax=`` (or ``axes=`` for a row of
panels) and returns what it drew on. Conventions, the same in every figure
(:mod:`~gearopt.plot.compare.common`):

* one colour per design (``C0``, ``C1``, ... in the order of the mapping; the first design drawn
  thicker, as the reference), named in every legend;
* one line style per misalignment case (:func:`case_style`), the case named in the panel title;
* panels of the same quantity share their scale (TE axes, flank frames, pressure colour scale).

Units: TE in arcsec (positive when the gear is ahead), pinion angle in deg, flank positions in mm,
torque in N m, pressure in MPa, micro-geometry amounts in um; safety and load factors (ISO 6336) and
Miner damage sums are dimensionless.

One module per group of quantities, each with its overlays and the figures it adds
(``*_figures(designs)``): :mod:`~gearopt.plot.compare.unloaded` (unloaded TE, paths of contact,
crowning), :mod:`~gearopt.plot.compare.loaded` (loaded TCA, contact patterns),
:mod:`~gearopt.plot.compare.samples` (Monte Carlo / sweep distributions),
:mod:`~gearopt.plot.compare.fea`, :mod:`~gearopt.plot.compare.rating` (ISO 6336),
:mod:`~gearopt.plot.compare.dynamics`; :mod:`~gearopt.plot.compare.figures` draws them all. The
``*_cases`` / ``*_of`` helpers pick a quantity out of the results of any study that has it, so that
designs of different studies are compared on what they have in common; they return ``None`` or
``[]`` when a design has no such quantity. This package re-exports the public names of its modules.
"""

from __future__ import annotations

from .common import (
    LEGEND_BELOW, case_key, case_name, case_style, design_color, floats, legend_below, line_width, match_cases,
    panel_grid,
)
from .dynamics import dynamics_figures
from .fea import fea_figures, fea_positions, plot_fea
from .figures import comparison_figures, save_figures
from .loaded import (
    common_torque, loaded_cases, loaded_figures, pattern_vmax, plot_load_sharing, plot_loaded_te,
    plot_pressure_vs_torque, plot_te_vs_torque,
)
from .rating import plot_rating_factor, plot_rating_spectrum, plot_safety, rating_figures, rating_of
from .samples import distribution_figures, plot_distribution
from .unloaded import (
    CROWNING_AMOUNTS, contact_path, crowning_amounts, crowning_figures, plot_contact_paths, plot_crowning, plot_te,
    te_cases, te_figures, te_range,
)

__all__ = ["comparison_figures", "save_figures", "design_color", "case_style", "case_key", "case_name",
           "te_cases", "match_cases", "contact_path", "loaded_cases", "crowning_amounts", "plot_te", "te_range",
           "plot_contact_paths", "plot_loaded_te", "plot_te_vs_torque", "plot_pressure_vs_torque", "plot_load_sharing",
           "plot_distribution", "plot_crowning", "pattern_vmax", "common_torque", "fea_positions", "plot_fea",
           "rating_of", "plot_safety", "plot_rating_factor", "plot_rating_spectrum", "CROWNING_AMOUNTS",
           "LEGEND_BELOW", "floats", "line_width", "legend_below", "panel_grid", "te_figures", "crowning_figures",
           "loaded_figures", "distribution_figures", "fea_figures", "rating_figures", "dynamics_figures"]
