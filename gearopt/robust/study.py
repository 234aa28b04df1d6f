"""Monte Carlo of tolerances and misalignments, and design sweeps (DOE), of unloaded TCA.

:class:`MonteCarlo` samples a crowned drive as built: misalignments from distributions, the
manufacturing deviations of an ISO 1328-1 flank tolerance class (helix slope f_Hbeta, profile slope
f_Halpha, single pitch f_pt of the teeth in mesh) and a centre-distance tolerance.
:class:`DesignSweep` runs a design of experiments over design variables (the TCA's parameters, e.g.
the pinion's a_c, a_pl, and misalignments as noise). Both evaluate every sample by one mesh cycle
of TCA through :class:`~gearopt.robust.batch.TCAKernel` in chunks, on any executor
(:mod:`gearopt.robust.execution`), and return a :class:`RobustResult` (per-sample table,
statistics, ranked sensitivities, plots).

Deviations act on the drive as one relative deviation carried by the pinion flank: the TCA sees the
gap between the flanks, which to first order is the sum of both members' normal deviations at the
contact point. Helix slopes add as ``f_Hb1 + f_Hb2 b1 / b2``; profile slopes, whose roll lengths
run opposite along the line of action, as ``f_Ha1 - f_Ha2 L_a1 / L_a2`` (L_a: the evaluation
ranges), plus a constant that moves every pair alike (no TE variation). Pitch deviations are exact
rigid offsets of the teeth in mesh (:mod:`gearopt.robust.batch`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ArgumentError, ConvergenceError, GearoptError, GeometryError, OptionError, out_of_range
from ..meshing.misalignment import Misalignment
from ..meshing.solver import DELTA_DEFAULT
from ..report import csv_cell
from ..units import ARCMIN, DEG, RAD_TO_ARCSEC
from .deviation import deviation_modification
from ..settings import MonteCarloSettings, RobustSettings, SweepSettings
from .sampling import Distribution, design, within_tolerance

if TYPE_CHECKING:  # pragma: no cover
    from ..gears import GearPair
    from ..ltca.compliance import Material

#: the deviation inputs a Monte Carlo can sample, with their unit (internal mm) and meaning
DEVIATIONS = {
    "pinion.f_H_alpha": "profile slope deviation of the pinion [mm]",
    "pinion.f_H_beta": "helix slope deviation of the pinion [mm]",
    "gear.f_H_alpha": "profile slope deviation of the gear [mm]",
    "gear.f_H_beta": "helix slope deviation of the gear [mm]",
    "pinion.f_pt_0": "single pitch deviation between pinion teeth -1 and 0 [mm]",
    "pinion.f_pt_1": "single pitch deviation between pinion teeth 0 and +1 [mm]",
    "gear.f_pt_0": "single pitch deviation between gear teeth -1 and 0 [mm]",
    "gear.f_pt_1": "single pitch deviation between gear teeth 0 and +1 [mm]",
}
PAIRS = (-1, 0, 1)
#: units of results.json of the montecarlo and sweep studies
UNITS = {"length": "mm", "angle": "rad (inputs in the CSV: arcmin)", "deviation": "um (suffix _um)",
         "te": "arcsec (suffix _arcsec)", "probability": "-", "time": "s", "see": "docs/results.md"}


def display(name: str, values: ArrayLike) -> tuple[np.ndarray, str]:
    """(values in the display unit, unit): arcmin for angles, um for deviations, 1/mm settings."""
    v = np.asarray(values, float)
    if name == "torque":
        return v, "N m"
    kind = name.split(".")[-1]
    if name.startswith("mis."):
        return (v / ARCMIN, "arcmin") if Misalignment.meta(kind)["unit"] == "angle" else (v, "mm")
    if name in DEVIATIONS or kind in ("C_alpha", "C_beta", "f_H_alpha", "f_H_beta", "S_alpha"):
        return v * 1000.0, "um"
    if kind in ("a_c", "a_pl"):
        return v, "1/mm"
    return v, "mm"


@dataclass
class RobustResult:
    """Per-sample table and statistics of a Monte Carlo or a design sweep (the one numeric
    output of :meth:`MonteCarlo.run` / :meth:`DesignSweep.run`). Data only: its figures are
    :func:`gearopt.plot.robust.save_plots` (the studies' ``RobustReport.save_plots``)."""

    study: str
    scene: str
    inputs: dict  #: name -> values (n,) [internal units]
    distributions: dict  #: name -> Distribution.to_dict() (internal units)
    figures: dict  #: te_p2p, h1..hH [rad], edge_contact, pattern_at_edge, pattern_z/r (n, 2) [mm], ok, n_failed
    pattern_count: np.ndarray  #: (rows radius, cols face) samples whose pattern covers the cell
    grid_z: np.ndarray
    grid_r: np.ndarray
    limits: dict  #: pinion b, r_a, r_form [mm]
    options: dict
    timing: dict = field(default_factory=dict)
    nominal: dict = field(default_factory=dict)  #: the nominal drive's figures (same kernel)
    warnings: list = field(default_factory=list)  #: texts of the study's warnings (mostly infeasible samples)

    @property
    def n(self) -> int:
        return int(self.figures["te_p2p"].size)

    def table(self) -> dict:
        """Columns of the per-sample CSV (name -> list): ``sample``, each input in its display unit
        (``<name>_<unit>``), ``te_p2p_arcsec``, ``h<k>_arcsec``, ``edge_contact``,
        ``pattern_at_edge``, the pattern extents on the pinion flank, ``feasible`` (0: the
        misalignment jams or separates the teeth; not solved), ``converged``."""
        cols = {"sample": list(range(self.n))}
        for nm, v in self.inputs.items():
            d, unit = display(nm, v)
            cols[f"{nm}_{unit.replace('/', '_per_')}"] = d.tolist()
        f = self.figures
        cols["te_p2p_arcsec"] = (f["te_p2p"] * RAD_TO_ARCSEC).tolist()
        for k in range(f["harmonics"].shape[1]):
            cols[f"h{k + 1}_arcsec"] = (f["harmonics"][:, k] * RAD_TO_ARCSEC).tolist()
        cols["edge_contact"] = f["edge_contact"].astype(int).tolist()
        cols["pattern_at_edge"] = f["pattern_at_edge"].astype(int).tolist()
        for j, end in enumerate(("min", "max")):
            cols[f"pattern_z_{end}_mm"] = f["pattern_z"][:, j].tolist()
        for j, end in enumerate(("min", "max")):
            cols[f"pattern_radius_{end}_mm"] = f["pattern_r"][:, j].tolist()
        if "loaded_te_p2p" in f:
            cols["loaded_te_p2p_arcsec"] = (f["loaded_te_p2p"] * RAD_TO_ARCSEC).tolist()
            cols["loaded_h1_arcsec"] = (f["loaded_harmonics"][:, 0] * RAD_TO_ARCSEC).tolist()
            cols["p_max_MPa"] = f["p_max"].tolist()
            cols["edge_share_max"] = f["edge_share_max"].tolist()
            cols["stiffness_mean_N_per_um"] = f["stiffness_mean"].tolist()
        cols["feasible"] = f["feasible"].astype(int).tolist()
        cols["converged"] = f["ok"].astype(int).tolist()
        return cols

    def statistics(self) -> dict:
        """Percentiles, mean and sd of TE p2p and of each harmonic [arcsec] (over samples whose
        TE is defined), probabilities of edge contact and of a truncated pattern (with Wilson 95 %
        intervals), and the number of failed samples."""
        f = self.figures
        feas = f["feasible"]
        out = {"n_samples": self.n, "n_failed": int((~f["ok"] & feas).sum()), "n_infeasible": int((~feas).sum()),
               "p_infeasible": _wilson(int((~feas).sum()), self.n),
               "feasible_fraction": usable_fraction(f)}
        qs = (1, 5, 50, 95, 99)

        def stats(v, scale=RAD_TO_ARCSEC):
            v = v[np.isfinite(v)] * scale
            if not v.size:
                return None
            return {"n": int(v.size), "mean": float(v.mean()), "sd": float(v.std(ddof=1)) if v.size > 1 else 0.0,
                    "min": float(v.min()), "max": float(v.max()),
                    **{f"p{q}": float(np.percentile(v, q)) for q in qs}}

        out["te_p2p_arcsec"] = stats(f["te_p2p"])
        for k in range(f["harmonics"].shape[1]):
            out[f"h{k + 1}_arcsec"] = stats(f["harmonics"][:, k])
        ok = f["ok"]
        for key in ("edge_contact", "pattern_at_edge"):
            out[f"p_{key}"] = _wilson(int(f[key][ok].sum()), int(ok.sum()))
        if "loaded_te_p2p" in f:
            out["loaded"] = {"n_failed": int((~f["loaded_ok"] & feas).sum()),
                             "te_p2p_arcsec": stats(f["loaded_te_p2p"]),
                             "h1_arcsec": stats(f["loaded_harmonics"][:, 0]),
                             "p_max_MPa": stats(f["p_max"], 1.0), "edge_share_max": stats(f["edge_share_max"], 1.0),
                             "stiffness_mean_N_per_um": stats(f["stiffness_mean"], 1.0)}
        return out

    def sensitivities(self) -> dict:
        """Inputs ranked by their influence on TE p2p (and on the first harmonic and on edge
        contact): ``{"te_p2p": [{"input", "spearman", "spearman_abs", "src"}, ...], ...}``.

        ``spearman``: rank correlation of the output with the input (monotonic effects);
        ``spearman_abs``: with the input's distance from its median (even effects, e.g. a pitch
        deviation of either sign raising TE); ``src``: standardised regression coefficient of a
        linear fit on all varied inputs. Ranked by the larger of the two |rho|."""
        from scipy.stats import spearmanr

        f = self.figures
        out = {}
        targets = [("te_p2p", f["te_p2p"]), ("h1", f["harmonics"][:, 0]),
                   ("edge_contact", f["edge_contact"].astype(float))]
        if "loaded_te_p2p" in f:
            targets += [("loaded_te_p2p", f["loaded_te_p2p"]), ("p_max", f["p_max"])]
        for key, y in targets:
            m = np.isfinite(y) & f["ok"]
            # the inputs that vary among these samples (an input constant over them has no influence to rank)
            names = [nm for nm, v in self.inputs.items() if m.any() and np.ptp(v[m]) > 0]
            if m.sum() < 3 or not names or np.ptp(y[m]) == 0:
                out[key] = []
                continue
            X = np.stack([self.inputs[nm][m] for nm in names], 1)
            Xs = (X - X.mean(0)) / X.std(0)
            ys = (y[m] - y[m].mean()) / y[m].std()
            src = np.linalg.lstsq(np.c_[Xs, np.ones(len(ys))], ys, rcond=None)[0][:-1]
            rows = []
            for j, nm in enumerate(names):
                rho = spearmanr(X[:, j], y[m]).statistic
                rho_abs = spearmanr(np.abs(X[:, j] - np.median(X[:, j])), y[m]).statistic
                rows.append({"input": nm, "spearman": float(rho) if np.isfinite(rho) else 0.0,
                             "spearman_abs": float(rho_abs) if np.isfinite(rho_abs) else 0.0, "src": float(src[j])})
            out[key] = sorted(rows, key=lambda r: -max(abs(r["spearman"]), abs(r["spearman_abs"])))
        return out

    def to_dict(self) -> dict:
        ins = {nm: {"distribution": self.distributions.get(nm), "unit": display(nm, 0.0)[1]} for nm in self.inputs}
        return {"study": self.study, "scene": self.scene, "units": UNITS, "options": self.options,
                "inputs": ins, "statistics": self.statistics(), "sensitivities": self.sensitivities(),
                "nominal": self.nominal, "limits": self.limits,
                "pattern": {"grid_z_mm": self.grid_z.tolist(), "grid_radius_mm": self.grid_r.tolist(),
                            "probability": (self.pattern_count / max(int(self.figures["ok"].sum()), 1)).tolist()},
                "samples_csv": "samples.csv", "timing": self.timing, "warnings": list(self.warnings)}

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """``samples.csv``: one row per sample (:meth:`table`)."""
        cols = self.table()
        text = ",".join(cols) + "\n" + "".join(",".join(csv_cell(v) for v in row) + "\n" for row in zip(*cols.values()))
        (Path(out_dir) / "samples.csv").write_text(text, encoding="utf-8")
        return ["samples.csv"]


def _wilson(k: int, n: int, z: float = 1.959963984540054) -> dict:
    """Proportion k/n with its Wilson score 95 % interval."""
    if n == 0:
        return {"p": None, "lo": None, "hi": None, "k": k, "n": n}
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return {"p": p, "lo": 0.0 if k == 0 else max(0.0, c - h), "hi": 1.0 if k == n else min(1.0, c + h), "k": k, "n": n}


class _Robust:
    """What the Monte Carlo and the design sweep share: the kernel, chunks and the run."""

    study = "robust"
    #: the class of :meth:`run`'s result (:class:`RobustResult`; the studies' subclass adds the plots)
    result_class: type[RobustResult] = RobustResult

    def _setup(self, pair: GearPair, settings: RobustSettings, delta: float, executor: Any, workers: int | None,
               name: str) -> None:
        from ..gears import GearPair
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {type(pair).__name__}: expected a gearopt.gears.GearPair.", param="pair",
                                value=type(pair).__name__, valid="a gearopt.gears.GearPair")
        self.settings = settings
        self.pair, self.name, self.side = pair, name, settings.side
        self.positions, self.chunk, self.seed = settings.positions, settings.chunk, settings.seed
        if not 0 < delta <= 0.1 * pair.pinion.m_n:
            raise out_of_range("delta", delta, f"0 < delta <= 0.1 m_n = {0.1 * pair.pinion.m_n:.4g} mm (elastic approach "
                               "of the contact ellipse)", cls=OptionError)
        self.delta = float(delta)
        from .execution import check_executor
        self.executor, self.workers = check_executor(executor, workers)

    def _kernel(self, tca, n_samples):
        from .batch import TCAKernel
        return TCAKernel(tca, positions=self.positions, pairs=PAIRS, delta=self.delta,
                         n_total=n_samples * self.positions * len(PAIRS))

    def _chunks(self, values: dict, n: int, kernel, tca) -> list[dict]:
        """The samples as chunks of parameter arrays (:meth:`TCAKernel.evaluate`'s keys)."""
        raise NotImplementedError

    def _execute(self, values: dict, n: int, progress=None, scheduler=None) -> tuple:
        from .execution import check_scheduler, run_chunks
        if scheduler is not None:
            check_scheduler(scheduler)
        t0 = time.perf_counter()
        tca = self._tca()
        kernel = self._kernel(tca, n).prepare()
        t_build = time.perf_counter() - t0
        chunks = self._chunks(values, n, kernel, tca)
        nominal = kernel.evaluate(self._nominal_chunk(kernel, tca))
        t1 = time.perf_counter()
        executor = "dask" if scheduler else self.executor
        try:
            parts = run_chunks(kernel, chunks, executor=executor, workers=self.workers, scheduler=scheduler,
                               progress=progress, label=self.study)
        except (GeometryError, ConvergenceError) as e:  # a sample's drive the engine cannot take: say which
            raise sample_error(self.study, values, e) from None
        t_run = time.perf_counter() - t1
        figs = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k != "pattern_count"}
        count = sum(p["pattern_count"] for p in parts)
        figs["feasible"] = self._ok_mis.copy()
        t_loaded = None
        if getattr(self, "torque", None) is not None:
            from .batch import LTCAKernel
            t2 = time.perf_counter()
            lk = LTCAKernel(self.pair, kernel.phi, PAIRS, deviation_mod="pinion.dev.f_H_alpha" in kernel.layout,
                            side=self.side, n_slices=self.n_slices, material=self.material)
            try:
                lparts = run_chunks(lk, chunks, executor=executor, workers=self.workers, scheduler=scheduler,
                                    progress=progress, label=f"{self.study} (loaded)")
            except OptionError as e:
                if getattr(e, "sample", None) is None:
                    raise
                raise sample_error(self.study, values, e) from None
            figs.update({k: np.concatenate([p[k] for p in lparts]) for k in lparts[0]})
            T0 = float(self.torque_dist.ppf(0.5))
            ln = lk.evaluate({**self._nominal_chunk(kernel, tca), "torque": np.array([T0])})
            nom_loaded = {"torque_Nm": T0, "loaded_te_p2p_arcsec": _num(ln["loaded_te_p2p"][0] * RAD_TO_ARCSEC),
                          "p_max_MPa": _num(ln["p_max"][0])}
            t_loaded = time.perf_counter() - t2
        nom = {"te_p2p_arcsec": _num(nominal["te_p2p"][0] * RAD_TO_ARCSEC),
               "h1_arcsec": _num(nominal["harmonics"][0, 0] * RAD_TO_ARCSEC),
               "edge_contact": bool(nominal["edge_contact"][0]),
               "pattern_z_mm": [_num(v) for v in nominal["pattern_z"][0]],
               "pattern_radius_mm": [_num(v) for v in nominal["pattern_r"][0]]}
        if t_loaded is not None:
            nom.update(nom_loaded)
        limits = {"b": self.pair.pinion.b, "r_a": self.pair.pinion.r_a, "r_form": float(tca.form_radius(1))}
        timing = {"build_s": t_build, "run_s": t_run, "n_columns": int(n * kernel.n_per_sample),
                  "us_per_position_pair": t_run / (n * kernel.n_per_sample) * 1e6, "executor": executor,
                  "workers": self.workers, "compiled": kernel.jit, "chunks": len(chunks)}
        if t_loaded is not None:
            timing["loaded_s"] = t_loaded
        return figs, count, kernel, nom, limits, timing

    def _nominal_chunk(self, kernel, tca):
        return {"p1": kernel.p1_0[None, :], "p2": kernel.p2_0[None, :], "mis": self.base_mis.vector()[None, :]}


#: below this fraction of usable samples a study warns (stderr and results.json ``warnings``)
FEASIBLE_WARN = 0.5


def usable_fraction(figs: dict) -> float:
    """Fraction of the samples with results: feasible (the misalignment neither jams nor separates
    the teeth) and solved (``ok``)."""
    use = np.asarray(figs["feasible"], bool) & np.asarray(figs["ok"], bool)
    return float(use.mean()) if use.size else 0.0


def judge_samples(study: str, figs: dict, values: dict, progress: Callable[[str], None] | None = None) -> list[str]:
    """Refuse a study none of whose samples has results (:class:`OptionError`: the inputs' ranges in
    the CSV's units); warn (``warnings.warn``, stderr, and the returned texts for results.json) when
    fewer than :data:`FEASIBLE_WARN` of them have."""
    import warnings

    feas, ok = np.asarray(figs["feasible"], bool), np.asarray(figs["ok"], bool)
    n = feas.size
    n_use = int((feas & ok).sum())
    why = (f"{int((~feas).sum())} infeasible (the misalignment jams or separates the teeth, or exceeds its limit), "
           f"{int((feas & ~ok).sum())} not solved")
    spans = ", ".join(f"{nm} {display(nm, np.min(v))[0]:.6g} ... {display(nm, np.max(v))[0]:.6g} {display(nm, 0.0)[1]}"
                      for nm, v in values.items() if np.ptp(v) > 0 and nm not in DEVIATIONS)
    if n_use == 0:
        raise OptionError(f"{study}: none of the {n} samples has results ({why}); the inputs span {spans}: narrow "
                          "the distributions / ranges to drives that mesh.", param=None)
    if n_use < FEASIBLE_WARN * n:
        msg = (f"{study}: only {n_use} of {n} samples ({100 * n_use / n:.3g} %) have results ({why}); the statistics "
               f"describe those alone. The inputs span {spans}: narrow them to drives that mesh.")
        if progress:  # the run's own stderr lines
            progress(f"warning: {msg}")
        else:
            warnings.warn(msg, UserWarning, stacklevel=3)
        return [msg]
    return []


def _feasible(pair, MIS) -> np.ndarray:
    """Per sample: the misalignment neither jams nor separates the teeth (the rules of
    :meth:`Misalignment.check`: dE within the operating range, faces overlapping)."""
    out = np.ones(len(MIS), bool)
    seen: dict = {}
    for i, v in enumerate(MIS):
        key = (v[Misalignment.names().index("dE")], v[Misalignment.names().index("axial")])
        if key not in seen:
            try:
                Misalignment(*v).check(pair)
                seen[key] = True
            except GeometryError:
                seen[key] = False
        out[i] = seen[key]
    return out


#: the parameters of each distribution kind that bound its values
BOUNDS_OF_KIND = {"fixed": ("value",), "uniform": ("lo", "hi"), "truncnormal": ("lo", "hi"),
                  "triangular": ("lo", "mode", "hi")}
#: standard deviations of a normal distribution that must lie within a misalignment's limit
NORMAL_SPAN = 3.0


def misalignment_limit(kind: str) -> float:
    """Largest magnitude of misalignment ``kind`` [rad or mm] that a fixed value may have (the
    bound of the scene keys, ``Misalignment.meta(kind)["scene_max"]``: deg for angles, mm for
    lengths); the Monte Carlo distributions and the sweep ranges obey the same one."""
    meta = Misalignment.meta(kind)
    return meta["scene_max"] * (DEG if meta["unit"] == "angle" else 1.0)


def misalignment_text(kind: str, value: float) -> str:
    """``value`` [rad or mm] of misalignment ``kind`` in the user's unit: arcmin (and deg from
    1 deg up) for angles, mm for lengths."""
    if Misalignment.meta(kind)["unit"] == "angle":
        return f"{value / ARCMIN:.6g} arcmin" + (f" ({value / DEG:.4g} deg)" if abs(value) >= DEG else "")
    return f"{value:.6g} mm"


def check_misalignment_distribution(kind: str, dist: Distribution, where: str) -> None:
    """Refuse a distribution of misalignment ``kind`` whose values reach beyond the limit of a fixed
    value (:func:`misalignment_limit`): its bounds (fixed, uniform, truncnormal, triangular) or, for a
    normal, ``mean +- NORMAL_SPAN sd`` (99.7 % of the samples). :class:`OptionError` naming
    ``where.<parameter>`` with the value in arcmin / mm."""
    lim = misalignment_limit(kind)
    valid = f"|{kind}| <= {misalignment_text(kind, lim)} (the limit of a fixed {kind})"
    if dist.kind == "normal":
        for p in ("mean", "sd"):
            v = getattr(dist, p)
            reach = abs(dist.mean) + NORMAL_SPAN * dist.sd
            if reach > lim and (p == "sd" or abs(dist.mean) > lim):
                detail = (f"is out of range: mean +- {NORMAL_SPAN:g} sd reaches {misalignment_text(kind, reach)}; "
                          f"valid: {valid} over mean +- {NORMAL_SPAN:g} sd.")
                raise OptionError(f"{where}.{p} = {misalignment_text(kind, v)} {detail}", param=f"{where}.{p}",
                                  value=misalignment_text(kind, v), valid=valid, detail=detail)
        return
    for p in BOUNDS_OF_KIND[dist.kind]:
        v = getattr(dist, p)
        if abs(v) > lim:
            detail = f"is out of range; valid: {valid}."
            raise OptionError(f"{where}.{p} = {misalignment_text(kind, v)} {detail}", param=f"{where}.{p}",
                              value=misalignment_text(kind, v), valid=valid, detail=detail)


def sample_error(study: str, values: dict, err: Exception, index: int | None = None) -> OptionError:
    """An error of one sample of a study, stated for that sample: its index and the value of every
    input (in the units of the CSV), with the error's own message. ``index``: the sample (default:
    the error's ``sample`` attribute, set by :meth:`TCAKernel.limit_tables`); without one the
    message gives the inputs' ranges."""
    index = getattr(err, "sample", None) if index is None else index
    names = list(values)
    if index is None:
        shown = ", ".join(f"{nm} in [{display(nm, np.min(values[nm]))[0]:.6g}, {display(nm, np.max(values[nm]))[0]:.6g}] "
                          f"{display(nm, 0.0)[1]}" for nm in names if nm not in DEVIATIONS)
        return OptionError(f"{study}: a sample failed ({err}); the inputs span {shown}: narrow the ranges.",
                           param=None, valid=getattr(err, "valid", None))
    shown = ", ".join(f"{nm} = {display(nm, values[nm][index])[0]:.6g} {display(nm, 0.0)[1]}" for nm in names
                      if nm not in DEVIATIONS)  # the ISO deviations (um) are in samples.csv of a run
    return OptionError(f"{study}: sample {index} ({shown}) failed: {err}", param=None,
                       valid=getattr(err, "valid", None))


def _num(v):
    v = float(v)
    return v if math.isfinite(v) else None


class MonteCarlo(_Robust):
    """Tolerance and misalignment Monte Carlo of a crowned drive's unloaded TCA.

    Parameters
    ----------
    pair : GearPair
        The drive (point contact: a crowned pinion).
    samples : int
        Number of samples (>= 1; required unless ``settings`` gives it).
    settings : gearopt.settings.MonteCarloSettings, optional
        ``samples``, ``seed``, ``sampling``, ``iso_grade``, ``spread``, ``f_a``, ``n_slices``,
        ``positions``, ``side``, ``chunk`` as one object; keyword arguments replace its fields. Their
        defaults and valid ranges are declared there only.
    seed : int
        Seed of the sampling (>= 0); the same seed gives the same samples and figures.
    misalignment : dict, optional
        Misalignment kind (``"crossing"``, ``"intersecting"``, ``"dE"``, ``"axial"``) ->
        :class:`~gearopt.robust.sampling.Distribution` [rad or mm].
    iso_grade : int, optional
        ISO 1328-1:2013 flank tolerance class 1 ... 11 of both members; samples the helix slope,
        profile slope and single pitch deviations within the tolerances (``spread``).
    spread : {"normal", "uniform"}
        How a deviation with tolerance +-T is distributed: N(0, (T/3)^2) truncated at +-T
        (a capable, centred process; default) or uniform on +-T.
    f_a : float
        Centre-distance tolerance +-f_a [mm] (ISO 1328-1 has none): dE sampled like a deviation.
    sampling : {"random", "lhs"}
        Monte Carlo (PCG64) or Latin hypercube.
    positions : int
        Positions per mesh cycle (default 64).
    delta : float
        Elastic approach of the contact ellipse [mm].
    chunk : int
        Samples per chunk (the unit of work of an executor; results do not depend on it).
    executor : {"serial", "processes", "dask"} or dask.distributed.Client
    workers : int, optional
        Processes (``"processes"``) or local Dask workers (``"dask"`` without a scheduler).
    """

    study = "montecarlo"

    def __init__(self, pair: GearPair, samples: int | None = None, settings: MonteCarloSettings | None = None, *,
                 misalignment: dict | None = None, delta: float = DELTA_DEFAULT, executor: Any = "serial",
                 workers: int | None = None, name: str = "montecarlo", torque: float | Distribution | None = None,
                 material: Material | None = None, **options: Any) -> None:
        if samples is not None:
            options["samples"] = samples
        if settings is None and "samples" not in options:
            raise ArgumentError("samples: missing; valid: the number of samples (an integer >= 1).", param="samples",
                                valid="an integer >= 1")
        s = MonteCarloSettings.of(settings, **options)
        self._setup(pair, s, delta, executor, workers, name)
        self.samples, self.sampling = s.samples, s.sampling
        spread, iso_grade, f_a, n_slices = s.spread, s.iso_grade, s.f_a, s.n_slices
        self.base_mis = Misalignment()
        inputs: dict[str, Distribution] = {}
        for kind, dist in (misalignment or {}).items():
            if kind not in Misalignment.names():
                raise out_of_range("misalignment", kind, f"one of {', '.join(Misalignment.names())}",
                                   cls=OptionError)
            if not isinstance(dist, Distribution):
                raise ArgumentError(f"misalignment[{kind!r}] = {type(dist).__name__}: expected a "
                                    "gearopt.robust.sampling.Distribution.", param=f"misalignment.{kind}")
            inputs[f"mis.{kind}"] = dist
        if f_a > 0:
            if "mis.dE" in inputs:
                raise OptionError("f_a and a dE distribution are both given: the centre-distance deviation is "
                                  "sampled from one of them; remove one.", param="f_a", value=f_a,
                                  valid="f_a or dE, not both")
            inputs["mis.dE"] = within_tolerance(f_a, spread, "f_a")
        self.tolerances = None
        if iso_grade is not None:
            from .tolerances import tolerances
            tol = {m: tolerances(iso_grade, 2 * g.r_p, g.m_n, g.b) for m, g in (("pinion", pair.pinion),
                                                                                   ("gear", pair.gear))}
            self.tolerances = tol
            for m in ("pinion", "gear"):
                inputs[f"{m}.f_H_alpha"] = within_tolerance(tol[m]["f_HalphaT"] / 1000, spread, f"{m}.f_H_alpha")
                inputs[f"{m}.f_H_beta"] = within_tolerance(tol[m]["f_HbetaT"] / 1000, spread, f"{m}.f_H_beta")
                for j in (0, 1):
                    inputs[f"{m}.f_pt_{j}"] = within_tolerance(tol[m]["f_pT"] / 1000, spread, f"{m}.f_pt_{j}")
        else:
            within_tolerance(1.0, spread, "spread")  # checks the name
        self.spread, self.iso_grade, self.f_a = spread, iso_grade, f_a
        self.torque, self.n_slices, self.material = torque, int(n_slices), material
        if torque is not None:
            if not isinstance(torque, Distribution):
                t = float(torque) if isinstance(torque, (int, float)) and not isinstance(torque, bool) else math.nan
                if not (math.isfinite(t) and t > 0):
                    raise out_of_range("torque", torque, "a pinion torque > 0 N m or a Distribution of it",
                                       cls=OptionError)
                torque = Distribution("fixed", value=t, name="torque")
            lo, _ = torque.support
            if not lo > 0:
                raise out_of_range("torque", torque.to_dict(), "a distribution of pinion torques > 0 N m (bounded "
                                   "below by a positive torque: uniform, truncnormal, triangular or fixed)",
                                   cls=OptionError)
            self.torque_dist = torque
            if math.isfinite(torque.support[1]):  # the largest torque drawn, against the model's range
                from ..ltca.validity import check_torque_range
                check_torque_range(pair, torque.support[1], material, name="torque.hi" if torque.kind != "fixed"
                                   else "torque.value")
        if not inputs:
            raise OptionError("MonteCarlo: nothing to sample: give misalignment distributions, iso_grade or f_a.",
                              param="misalignment", valid="at least one random input")
        self.inputs = inputs
        if torque is not None:
            self.inputs["torque"] = self.torque_dist
        for nm, d in inputs.items():
            if nm.startswith("mis."):
                check_misalignment_distribution(nm[4:], d, f"misalignment.{nm[4:]}")

    def _tca(self):
        from ..geometry.microgeometry import modified_tooth
        from ..meshing.tca import TCA
        pinion = modified_tooth(self.pair, "pinion")
        if any(nm in self.inputs for nm in DEVIATIONS if "f_H" in nm):
            mod, self._frame1 = deviation_modification(self.pair)
            pinion = pinion.with_modification(mod)
            from ..geometry.generation import generate
            from ..geometry.microgeometry import frame
            self._frame2 = frame(generate(self.pair.gear), "right", self.pair, "gear")
        return TCA(self.pair, side=self.side, pinion=pinion, contact="point")

    def values(self) -> dict:
        """The sampled inputs (name -> (samples,) [internal units])."""
        return design(self.inputs, self.sampling, self.samples, self.seed)

    def _chunks(self, values, n, kernel, tca):
        lay = kernel.layout
        P1 = np.tile(kernel.p1_0, (n, 1))
        P2 = np.tile(kernel.p2_0, (n, 1))
        MIS = np.tile(self.base_mis.vector(), (n, 1))
        for j, kind in enumerate(Misalignment.names()):
            if f"mis.{kind}" in values:
                MIS[:, j] = values[f"mis.{kind}"]
        z0 = np.zeros(n)
        g = lambda k: values.get(k, z0)  # noqa: E731
        if "pinion.dev.f_H_alpha" in lay:
            off = lay.groups["pinion"].start
            f1, f2 = self._frame1, self._frame2
            P1[:, lay.index("pinion.dev.f_H_alpha") - off] += g("pinion.f_H_alpha") - g("gear.f_H_alpha") * f1.L_alpha / f2.L_alpha
            P1[:, lay.index("pinion.dev.f_H_beta") - off] += g("pinion.f_H_beta") + g("gear.f_H_beta") * f1.b / f2.b
        # pitch: tooth positions relative to tooth 0 of each member (pairs -1, 0, +1), as angles
        r1, r2 = self.pair.pinion.r_p, self.pair.gear.r_p
        e1 = np.stack([-g("pinion.f_pt_0"), z0, g("pinion.f_pt_1")], 1) / r1
        e2 = np.stack([-g("gear.f_pt_0"), z0, g("gear.f_pt_1")], 1) / r2
        self._ok_mis = _feasible(self.pair, MIS)
        T = values.get("torque", np.full(n, np.nan))
        return [{"p1": P1[s:s + self.chunk], "p2": P2[s:s + self.chunk], "mis": MIS[s:s + self.chunk],
                 "e1": e1[s:s + self.chunk], "e2": e2[s:s + self.chunk], "skip": ~self._ok_mis[s:s + self.chunk],
                 "torque": T[s:s + self.chunk], "first": s} for s in range(0, n, self.chunk)]

    def run(self, progress: Callable[[str], None] | None = None, scheduler: str | None = None) -> RobustResult:
        """Sample, solve every sample's mesh cycle, reduce. ``progress``: callable(str) for
        progress lines (a progress bar is shown on stderr when given); ``scheduler``: a Dask
        scheduler address that overrides the executor."""
        if progress:
            progress(f"montecarlo: {self.samples} samples x {self.positions} positions x {len(PAIRS)} pairs")
        values = self.values()
        figs, count, kernel, nom, limits, timing = self._execute(values, self.samples, progress, scheduler)
        warns = judge_samples("montecarlo", figs, values, progress)
        opts = {"samples": self.samples, "seed": self.seed, "sampling": self.sampling, "positions": self.positions,
                "pairs": list(PAIRS), "iso_grade": self.iso_grade, "spread": self.spread, "f_a_mm": self.f_a,
                "delta_mm": self.delta, "side": self.side, "chunk": self.chunk}
        if self.tolerances is not None:
            opts["tolerances_um"] = self.tolerances
        return self.result_class("montecarlo", self.name, values, {k: d.to_dict() for k, d in self.inputs.items()},
                                 figs, count, kernel.grid_z, kernel.grid_r, limits, opts, timing, nom, warns)


class DesignSweep(_Robust):
    """Design sweep / DOE of a crowned drive's unloaded TCA over design variables.

    Parameters
    ----------
    pair : GearPair
    variables : dict
        name -> (lo, hi) [internal units]: any entry of the TCA's parameter vector
        (``"pinion.a_c"``, ``"pinion.a_pl"``, ``"pinion.iso.C_beta"``... see
        :class:`~gearopt.meshing.layout.ParamLayout`) or a misalignment ``"mis.<kind>"``.
    design : {"lhs", "full_factorial", "random"}
    samples : int
        Points of an LHS / random design.
    levels : int
        Levels per variable of a full factorial (ends included).
    settings : gearopt.settings.SweepSettings, optional
        ``design``, ``samples``, ``levels``, ``seed``, ``positions``, ``side``, ``chunk`` as one
        object; keyword arguments replace its fields. Their defaults (``samples`` 64) and valid
        ranges are declared there only.
    misalignment : Misalignment
        The drive's misalignment besides the swept kinds.
    positions, side, chunk, delta, executor, workers
        As :class:`MonteCarlo`.
    """

    study = "sweep"

    def __init__(self, pair: GearPair, variables: dict, settings: SweepSettings | None = None, *,
                 misalignment: Misalignment | None = None, delta: float = DELTA_DEFAULT, executor: Any = "serial",
                 workers: int | None = None, name: str = "sweep", **options: Any) -> None:
        s = SweepSettings.of(settings, **options)
        self._setup(pair, s, delta, executor, workers, name)
        self.design = s.design
        self.samples = s.samples if s.design != "full_factorial" else None
        self.levels = s.levels if s.design == "full_factorial" else None
        if misalignment is not None and not isinstance(misalignment, Misalignment):
            raise ArgumentError("misalignment: expected a Misalignment.", param="misalignment")
        self.base_mis = misalignment or Misalignment()
        self.base_mis.check(pair, "misalignment")
        if not variables:
            raise OptionError("DesignSweep: no variables to sweep.", param="variables", valid="at least one variable")
        self.variables = {}
        for nm, rng in variables.items():
            try:
                lo, hi = (float(v) for v in rng)
            except (TypeError, ValueError):
                raise out_of_range(f"variables.{nm}", rng, "(lo, hi)", cls=OptionError) from None
            self.variables[nm] = Distribution("uniform", lo=lo, hi=hi, name=f"variables.{nm}")
            for v in (lo, hi):
                self._check_corner(nm, v)
        self._probe = None

    def _check_corner(self, nm: str, v: float) -> None:
        """The validation a fixed value gets, at an end ``v`` of the range of variable ``nm``: a
        misalignment within its limit (:func:`misalignment_limit`) that neither jams nor separates
        the teeth (:meth:`Misalignment.check`); a crowning setting ``<member>.a_c`` / ``a_pl`` that
        builds a valid gear (:class:`~gearopt.gears.Gear`) whose generated flank reaches inside the
        tip circle without folding at the face centre and ends (:meth:`flank_limit`). Raises the
        error naming ``variables.<nm>`` and the end's value."""
        from dataclasses import replace

        from ..geometry.generation import generate

        where = f"variables.{nm}"
        if nm.startswith("mis."):
            kind = nm[4:]
            if kind not in Misalignment.names():
                return  # refused by _tca with the valid names
            lim = misalignment_limit(kind)
            valid = f"|{kind}| <= {misalignment_text(kind, lim)} (the limit of a fixed {kind})"
            if abs(v) > lim:
                detail = f"is out of range at its end {misalignment_text(kind, v)}; valid: {valid}."
                raise OptionError(f"{where} = {misalignment_text(kind, v)} {detail}", param=where,
                                  value=misalignment_text(kind, v), valid=valid, detail=detail)
            try:
                replace(self.base_mis, **{kind: v}).check(self.pair, "mis")
            except GeometryError as e:
                detail = f"is out of range at its end {misalignment_text(kind, v)}; valid: {e.valid}."
                raise OptionError(f"{where} = {misalignment_text(kind, v)} {detail}", param=where,
                                  value=misalignment_text(kind, v), valid=e.valid, detail=detail) from None
            return
        member, _, key = nm.partition(".")
        if member not in ("pinion", "gear") or key not in ("a_c", "a_pl"):
            return
        g = getattr(self.pair, member)
        unit = "1/mm"
        try:
            g2 = g.with_(rack=replace(g.rack, a_c=v)) if key == "a_c" else g.with_(a_pl=v)
            tooth = generate(g2)
            for z in (0.0, g2.b / 2):
                tooth.flank_limit("right", z)
        except GearoptError as e:
            why = e.valid if (e.detail or "").startswith(("is out of range", "must be")) and e.valid else None
            valid = why or f"a {key} whose generated {member} flank is valid ({e})"
            detail = f"is out of range at its end {v:.6g} {unit}; valid: {valid}."
            raise OptionError(f"{where} = {v:.6g} {unit} {detail}", param=where, value=v, valid=valid,
                              detail=detail) from None

    def _tca(self):
        from ..meshing.tca import TCA
        tca = TCA(self.pair, side=self.side, contact="point")
        for nm in self.variables:
            if nm.startswith("mis."):
                if nm[4:] not in Misalignment.names():
                    raise out_of_range("variables", nm, f"mis.<kind> with kind one of {', '.join(Misalignment.names())}",
                                       cls=OptionError)
            elif nm not in tca.layout or nm in ("phi1", "z_section") or nm in tca.layout.groups:
                valid = [x for x in tca.layout.names if x not in ("phi1", "z_section") and not x.startswith("mis.")]
                raise out_of_range("variables", nm, f"a TCA parameter ({', '.join(valid)}) or mis.<kind>",
                                   cls=OptionError)
        return tca

    def values(self) -> dict:
        n = self.samples if self.samples is not None else 0
        return design(self.variables, self.design, n, self.seed, self.levels)

    def _chunks(self, values, n, kernel, tca):
        lay = kernel.layout
        P1 = np.tile(kernel.p1_0, (n, 1))
        P2 = np.tile(kernel.p2_0, (n, 1))
        MIS = np.tile(self.base_mis.vector(), (n, 1))
        for nm, v in values.items():
            if nm.startswith("mis."):
                MIS[:, Misalignment.names().index(nm[4:])] = v
            elif nm.startswith("pinion."):
                P1[:, lay.index(nm) - lay.groups["pinion"].start] = v
            else:
                P2[:, lay.index(nm) - lay.groups["gear"].start] = v
        try:
            ulim = kernel.limit_tables(tca, P1, P2)
        except GearoptError as e:  # a design point whose flank is degenerate: name it and its values
            raise sample_error(self.study, values, e) from None
        self._ok_mis = _feasible(self.pair, MIS)
        return [{"p1": P1[s:s + self.chunk], "p2": P2[s:s + self.chunk], "mis": MIS[s:s + self.chunk],
                 "ulim": ulim[s:s + self.chunk], "skip": ~self._ok_mis[s:s + self.chunk]}
                for s in range(0, n, self.chunk)]

    def run(self, progress: Callable[[str], None] | None = None, scheduler: str | None = None) -> RobustResult:
        values = self.values()
        n = len(next(iter(values.values())))
        if progress:
            progress(f"sweep: {n} design points ({self.design}) x {self.positions} positions x {len(PAIRS)} pairs")
        figs, count, kernel, nom, limits, timing = self._execute(values, n, progress, scheduler)
        warns = judge_samples("sweep", figs, values, progress)
        opts = {"design": self.design, "samples": n, "levels": self.levels, "seed": self.seed,
                "positions": self.positions, "pairs": list(PAIRS), "delta_mm": self.delta, "side": self.side,
                "chunk": self.chunk, "misalignment": self.base_mis.to_results()}
        return self.result_class("sweep", self.name, values, {k: d.to_dict() for k, d in self.variables.items()},
                                 figs, count, kernel.grid_z, kernel.grid_r, limits, opts, timing, nom, warns)
