"""Random and designed inputs of the robust-design studies: distributions, seeded Monte Carlo,
Latin hypercube (scipy.stats.qmc) and full factorial designs.

Every design is built the same way: points ``U`` in the unit cube (one column per input), then
each column mapped through its input's inverse CDF (:meth:`Distribution.ppf`). Monte Carlo draws
``U`` from ``numpy.random.Generator(PCG64(seed))``; the Latin hypercube from
``scipy.stats.qmc.LatinHypercube(d, rng=seed)``; the full factorial puts ``levels`` points on
the midpoints of equal-probability cells of each input (for a uniform input: equally spaced, ends
included when ``ends=True``). A design depends only on the seed, the inputs and the count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError, check_number, out_of_range

KINDS = ("fixed", "uniform", "normal", "truncnormal", "triangular")  #: distribution kinds
PARAMS = {"fixed": ("value",), "uniform": ("lo", "hi"), "normal": ("mean", "sd"),
          "truncnormal": ("mean", "sd", "lo", "hi"), "triangular": ("lo", "mode", "hi")}


@dataclass(frozen=True)
class Distribution:
    """A one-dimensional distribution in internal units (mm, rad, 1/mm).

    Parameters
    ----------
    kind : {"fixed", "uniform", "normal", "truncnormal", "triangular"}
    value : float
        ``fixed``.
    lo, hi : float
        Bounds of ``uniform``, ``truncnormal`` (truncation) and ``triangular``.
    mean, sd : float
        ``normal`` and ``truncnormal`` (of the untruncated normal; sd > 0).
    mode : float
        ``triangular``.
    name : str
        The input it belongs to (error messages).
    """

    kind: str
    value: float = 0.0
    lo: float = math.nan
    hi: float = math.nan
    mean: float = 0.0
    sd: float = math.nan
    mode: float = math.nan
    name: str = "distribution"

    def __post_init__(self) -> None:
        n = self.name
        if self.kind not in KINDS:
            raise out_of_range(f"{n}.kind", self.kind, f"one of {', '.join(KINDS)}", cls=OptionError)
        for p in PARAMS[self.kind]:
            object.__setattr__(self, p, check_number(f"{n}.{p}", getattr(self, p), "a finite number", cls=OptionError))
        k = self.kind
        if k in ("normal", "truncnormal") and not self.sd > 0:
            raise out_of_range(f"{n}.sd", self.sd, "sd > 0 (standard deviation)", cls=OptionError)
        if k in ("uniform", "truncnormal", "triangular") and not self.lo < self.hi:
            raise out_of_range(f"{n}.hi", self.hi, f"hi > lo = {self.lo:g} (a range of non-zero width)",
                               cls=OptionError)
        if k == "triangular" and not self.lo <= self.mode <= self.hi:
            raise out_of_range(f"{n}.mode", self.mode, f"lo <= mode <= hi ({self.lo:g} ... {self.hi:g})",
                               cls=OptionError)
        if k == "truncnormal" and ((self.lo - self.mean) / self.sd > 8 or (self.hi - self.mean) / self.sd < -8):
            raise out_of_range(f"{n}.lo", self.lo, f"a range that meets the normal's bulk (mean {self.mean:g} +- 8 sd)",
                               cls=OptionError)

    def ppf(self, u: ArrayLike) -> np.ndarray:
        """Inverse CDF at ``u`` in [0, 1) (array)."""
        from scipy.special import ndtr, ndtri

        u = np.asarray(u, float)
        k = self.kind
        if k == "fixed":
            return np.full(u.shape, self.value)
        if k == "uniform":
            return self.lo + (self.hi - self.lo) * u
        if k == "normal":
            return self.mean + self.sd * ndtri(np.clip(u, 1e-16, 1 - 1e-16))
        if k == "truncnormal":
            a, b = ndtr((self.lo - self.mean) / self.sd), ndtr((self.hi - self.mean) / self.sd)
            x = self.mean + self.sd * ndtri(np.clip(a + (b - a) * u, 1e-16, 1 - 1e-16))
            return np.clip(x, self.lo, self.hi)
        # triangular
        c = (self.mode - self.lo) / (self.hi - self.lo)
        w = self.hi - self.lo
        return np.where(u < c, self.lo + np.sqrt(u * w * (self.mode - self.lo)),
                        self.hi - np.sqrt((1 - u) * w * (self.hi - self.mode)))

    @property
    def support(self) -> tuple[float, float]:
        """(lowest, highest) value it can take (+-inf for the normal)."""
        k = self.kind
        if k == "fixed":
            return self.value, self.value
        if k == "normal":
            return -math.inf, math.inf
        return self.lo, self.hi

    def to_dict(self) -> dict:
        return {"kind": self.kind, **{p: getattr(self, p) for p in PARAMS[self.kind]}}


def within_tolerance(T: float, spread: str, name: str) -> Distribution:
    """A manufacturing deviation of tolerance +-T: ``"normal"`` (a capable, centred process:
    N(0, (T/3)^2) truncated at +-T) or ``"uniform"`` on [-T, T]; ``fixed`` 0 when T = 0."""
    if T == 0:
        return Distribution("fixed", value=0.0, name=name)
    if spread == "normal":
        return Distribution("truncnormal", mean=0.0, sd=T / 3, lo=-T, hi=T, name=name)
    if spread == "uniform":
        return Distribution("uniform", lo=-T, hi=T, name=name)
    raise out_of_range("spread", spread, "'normal' (N(0, (T/3)^2) within +-T) or 'uniform' (on +-T)",
                       cls=OptionError)


def check_count(name: str, n: int, lo: int = 1, hi: int = 10_000_000) -> int:
    """A sample / level count: an integer lo ... hi."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not lo <= n <= hi:
        raise out_of_range(name, n, f"an integer {lo} ... {hi}", cls=OptionError)
    return int(n)


def unit_design(method: str, n: int, d: int, seed: int, levels: int | None = None) -> np.ndarray:
    """Points in the unit cube, (n, d): ``"random"`` (Monte Carlo), ``"lhs"`` (Latin hypercube,
    scrambled cells, optimisation off) or ``"full_factorial"`` (``levels`` per input, n = levels^d,
    ``n`` ignored; levels at the cell midpoints (k + 0.5) / levels)."""
    if method == "random":
        return np.random.Generator(np.random.PCG64(seed)).random((n, d))
    if method == "lhs":
        from scipy.stats import qmc
        if d == 0:
            return np.zeros((n, 0))
        return qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n)
    if method == "full_factorial":
        lv = (np.arange(levels) + 0.5) / levels
        grids = np.meshgrid(*([lv] * d), indexing="ij")
        return np.stack([g.ravel() for g in grids], axis=1) if d else np.zeros((1, 0))
    raise out_of_range("design", method, "'random', 'lhs' or 'full_factorial'", cls=OptionError)


def design(inputs: dict, method: str, n: int, seed: int, levels: int | None = None,
           ends: bool = True) -> dict:
    """Values of the ``inputs`` (name -> :class:`Distribution`) at the points of a design.

    Parameters
    ----------
    inputs : dict
        name -> Distribution (internal units); their order is the column order of the design.
    method : {"random", "lhs", "full_factorial"}
    n : int
        Number of points (random, lhs).
    seed : int
        Seed (the same seed, inputs and n give the same points).
    levels : int
        Levels per input (full factorial).
    ends : bool
        Full factorial of uniform inputs: levels from lo to hi inclusive (default), else cell midpoints.

    Returns
    -------
    dict
        name -> array (n,) of values.
    """
    names = list(inputs)
    seed = check_count("seed", seed, 0, 2**63 - 1)
    if method == "full_factorial":
        levels = check_count("levels", levels, 2, 101)
        if levels ** len(names) > 1_000_000:
            raise out_of_range("levels", levels, f"levels^{len(names)} <= 1e6 design points", cls=OptionError)
    else:
        n = check_count("samples", n)
    U = unit_design(method, n, len(names), seed, levels)
    out = {}
    for j, nm in enumerate(names):
        dist = inputs[nm]
        u = U[:, j]
        if method == "full_factorial" and ends and dist.kind == "uniform":
            u = np.round((u * levels - 0.5)) / (levels - 1)
        out[nm] = dist.ppf(u)
    return out
