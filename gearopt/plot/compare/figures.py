"""Every comparison figure of ``gearopt compare`` (:mod:`gearopt.plot.compare`), drawn and saved: the
figures of each group of quantities (unloaded drive, loaded drive, samples, FE, crowning, rating,
dynamics), in the order the comparison page shows them.

Units: the figures' own (see each group's module); resolution in dots per inch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .dynamics import dynamics_figures
from .fea import fea_figures
from .loaded import loaded_figures
from .rating import rating_figures
from .samples import distribution_figures
from .unloaded import crowning_figures, te_figures

if TYPE_CHECKING:
    from collections.abc import Mapping

    import numpy as np

__all__ = ["comparison_figures", "save_figures"]


def comparison_figures(designs: Mapping[str, dict], samples: Mapping[str, Mapping[str, np.ndarray]] | None = None
                       ) -> list[tuple[str, str, Any]]:
    """Every comparison figure the designs have data for (not saved; :func:`save_figures` saves them).

    A figure is drawn when at least two designs have its quantity (a design without it is named in
    the panel titles or left out of the legend).

    Parameters
    ----------
    designs : mapping label -> results dict
    samples : mapping label -> {column: values}, optional
        The samples tables of Monte Carlo / sweep designs (for the distributions).

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
        Each with a one-line caption saying what to read from it.
    """
    return (te_figures(designs) + loaded_figures(designs) + distribution_figures(samples) + fea_figures(designs)
            + crowning_figures(designs) + rating_figures(designs) + dynamics_figures(designs))


def save_figures(designs: Mapping[str, dict], directory: Any, samples: Mapping[str, Mapping[str, np.ndarray]] | None = None,
                 dpi: int = 120) -> list[tuple[str, str]]:
    """Draw every comparison figure (:func:`comparison_figures`) into ``directory`` as PNG.

    Returns
    -------
    list of (file name, caption)
    """
    import matplotlib.pyplot as plt
    from pathlib import Path

    out = []
    for name, caption, fig in comparison_figures(designs, samples):
        fig.tight_layout()
        fig.savefig(Path(directory) / name, dpi=dpi)
        plt.close(fig)
        out.append((name, caption))
    return out
