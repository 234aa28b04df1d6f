"""The loaded micro-geometry problem: the drive, the free amounts with their bounds, the duty cycle
(torques x misalignment cases, weights) and the limits, with the checks of every argument
(:class:`LoadedProblem`, the base of :class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ...compiled import available, background
from ...errors import ArgumentError, OptionError, out_of_range
from ...gears import GearPair
from ...geometry.microgeometry import AMOUNT_MAX_PER_M, RELIEF_AMOUNTS, Microgeometry, modified_tooth
from ...ltca.compliance import Material
from ...ltca.engine import LTCA
from ...meshing.misalignment import Misalignment
from ...meshing.tca import TCA
from ...settings import LoadedMicroSettings
from .constants import NONNEG, SETTINGS


class LoadedProblem:
    """The problem's data and the checks of every argument (parameters: :class:`LoadedMicroOptimizer`)."""

    def __init__(self, pair: GearPair, free: dict, torques: Sequence[float],
                 cases: Sequence[Misalignment] | None = None, weights: npt.ArrayLike | None = None,
                 settings: LoadedMicroSettings | None = None, *, material: Material | None = None,
                 jit: bool | str = "auto", **options: Any):
        # the options (p_limit, edge_margin, n_positions, ...): defaults and checks are those of LoadedMicroSettings
        s = LoadedMicroSettings.of(settings, **options)
        self.settings = s
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {pair!r:.60}: expected a gearopt.gears.GearPair.", param="pair", value=pair,
                                valid="a gearopt.gears.GearPair")
        self.pair = pair
        self.torques = LTCA.validate_torques(torques)
        cases = [Misalignment()] if cases is None else list(cases)
        if not cases or not all(isinstance(c, Misalignment) for c in cases):
            raise ArgumentError("cases: expected a non-empty list of gearopt Misalignment.", param="cases",
                                value=cases, valid="a list of Misalignment")
        self.cases = tuple(cases)
        T, C = self.torques.size, len(self.cases)
        w = np.ones((T, C)) if weights is None else np.asarray(weights, float)
        if w.shape != (T, C) or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.sum() > 0:
            raise ArgumentError(f"weights: expected a ({T}, {C}) array (torques x cases) of finite weights >= 0, "
                                "not all 0.", param="weights", value=np.shape(w), valid=f"shape ({T}, {C}), >= 0")
        self.weights = w
        self.p_limit, self.edge_margin, self.n_verify = s.p_limit, s.edge_margin, s.n_verify
        self.n_confirm, self.confirm_tol, self.max_exchanges = s.n_confirm, s.confirm_tol, s.max_exchanges
        self.exchange = s.exchange
        self.harmonics = None if s.harmonics is None else np.array(s.harmonics, float)
        self.te_level, self.te_weight = s.te_level, s.te_weight
        n_positions, n_slices, side = s.n_positions, s.n_slices, s.side
        self.free, self.lo, self.hi = self._check_free(free)
        if not (isinstance(jit, (bool, np.bool_)) or (isinstance(jit, str) and jit == "auto")):
            raise out_of_range("jit", jit, "'auto', True or False (solve the slices as compiled C)", cls=OptionError)
        # the loop solves the slices of every case several hundred columns at a time, dozens of times:
        # compiled whenever a C compiler is present (8x faster than interpreted at 500 columns). Under
        # "auto" the slices' libraries are the disk cache's whenever they are there; on a cache miss (a
        # first run) a solve of fewer than compiled.MIN_COLUMNS columns runs interpreted while its
        # library compiles in the background, and the loop's later solves pick it up (gearopt.compiled
        # .select), instead of every solve waiting for five compiles before the first linearisation. With
        # the background compiles off (GEAROPT_JIT_BACKGROUND=0, the test suite) a miss compiles at once,
        # as under jit=True: "auto" would then leave the loop's slices interpreted for good
        tca_jit = "auto" if jit == "auto" and background() else (available() if jit == "auto" else bool(jit))
        jit = available() if jit == "auto" else bool(jit)
        self.jit = jit  #: whether the slices and the separations' sensitivities run as compiled C
        self.tca = TCA(pair, side=side, pinion=modified_tooth(pair, "pinion", force_iso=True),
                       gear=modified_tooth(pair, "gear", force_iso=True), jit=tca_jit)
        # the default loaded TCA (each flank's own curvature in the Hertz term, docs/ltca.md section 3): the
        # linearisation, the trust region's exact steps and the verification all use it, and the NLP's
        # pressure rows its curvature linearised in the design (docs/loaded_synthesis.md section 3)
        self.ltca = LTCA(pair, side=side, material=material, n_slices=n_slices, tca=self.tca)
        self.material = self.ltca.material
        self.n_positions = int(n_positions)
        self.phi1 = self.ltca.mesh_cycle(self.n_positions)
        lay = self.tca.layout
        self._prm_index = [lay.index(f"{m}.{member_entry(a)}") for m, a in (n.split(".", 1) for n in self.free)]
        self._prm_index += [lay.index(f"mis.{k}") for k in Misalignment.names()]  # then the misalignments
        self.p0 = (np.array(self.tca.pinion.p0, float), np.array(self.tca.gear.p0, float))
        self.theta0 = np.array([self.p0[0 if m == "pinion" else 1][lay.member_names[m].index(member_entry(a))]
                                for m, a in (n.split(".", 1) for n in self.free)])
        bad = [(n, t) for n, t, a, b in zip(self.free, self.theta0, self.lo, self.hi) if not a <= t <= b]
        if bad:
            n, t = bad[0]
            i = self.free.index(n)
            k, u = (1.0, "1/mm") if n.split(".", 1)[1] in SETTINGS else (1e3, "um")
            raise out_of_range(f"free.{n}", f"{float(t) * k:g} {u}", f"the start design's {n} must lie within its bounds "
                               f"{self.lo[i] * k:g} ... {self.hi[i] * k:g} {u}", cls=OptionError)
        self._sens = {}
        self._sens_maps = {}  #: per slice kind, the sensitivities on columns (:meth:`Lineariser.sensitivity_columns`)
        #: the newest linearisations and their loaded TCA (:meth:`Lineariser.linearise`, ``exact_sweeps``), shared
        #: with this optimiser's copies (the reduced cases', a Pareto point's)
        self._lin_memo, self._lin_sweeps = {}, {}
        self._has_settings = any(n.split(".", 1)[1] in SETTINGS for n in self.free)
        #: the penalty's weight scale (that of the full duty cycle; an unloaded-TE target adds its weight: its
        #: term weighs te_weight times the loaded objective's per case, and so may its multipliers)
        self._w_mean = float(np.mean(self.weights)) * (1.0 + (self.te_weight if self.te_level is not None else 0.0))
        self._mult = np.ones((T, C))  #: how many cases of the duty cycle each (torque, case) stands for
        #: the last trust-region pass's final NLP, its solution, parameters and radius (:meth:`_trust_region`)
        self.last_solve: tuple | None = None


    # ------------------------------------------------------------------------------------------
    def _check_free(self, free):
        if not isinstance(free, dict) or not free:
            raise ArgumentError("free: expected a dict {'pinion.C_alpha': (lo, hi), ...} of free amounts [mm].",
                                param="free", value=free, valid="a non-empty dict name -> (lo, hi) [mm]")
        names, lo, hi = [], [], []
        for name, b in free.items():
            member, _, amount = str(name).partition(".")
            gear = getattr(self.pair, member, None) if member in ("pinion", "gear") else None
            valid = [f"{m}.{a}" for m in ("pinion", "gear") for a in self._amounts(getattr(self.pair, m)) + tuple(SETTINGS)]
            if amount in SETTINGS and gear is not None:
                # Litvin's settings [1/mm]: parabolic rack-cutter profile a_c, plunging (lead crowning) a_pl
                try:
                    a, c = (float(v) for v in b)
                except (TypeError, ValueError):
                    raise out_of_range(f"free.{name}", b, "a pair (lo, hi) [1/mm]", cls=OptionError) from None
                if not (math.isfinite(a) and math.isfinite(c) and 0.0 <= a < c <= SETTINGS[amount]):
                    raise out_of_range(f"free.{name}", f"({a:g}, {c:g}) 1/mm",
                                       f"0 <= lo < hi <= {SETTINGS[amount]:g} 1/mm", cls=OptionError)
                names.append(f"{member}.{amount}")
                lo.append(a)
                hi.append(c)
                continue
            if gear is None or amount not in self._amounts(gear):
                hint = ""
                if gear is not None and amount in RELIEF_AMOUNTS:
                    hint = " (a relief needs its start, e.g. d_Ca, in the member's modifications)"
                raise out_of_range(f"free.{name}", name, f"one of {valid}{hint}", cls=OptionError)
            try:
                a, c = (float(v) for v in b)
            except (TypeError, ValueError):
                raise out_of_range(f"free.{name}", b, "a pair (lo, hi) of amounts [mm]", cls=OptionError) from None
            cap = AMOUNT_MAX_PER_M * gear.m_n
            low = 0.0 if amount in NONNEG else -cap
            if not (math.isfinite(a) and math.isfinite(c) and low <= a < c <= cap):
                raise out_of_range(f"free.{name}", f"({a * 1e3:g}, {c * 1e3:g}) um",
                                   f"{low * 1e3:g} um <= lo < hi <= {cap * 1e3:g} um", cls=OptionError)
            names.append(f"{member}.{amount}")
            lo.append(a)
            hi.append(c)
        return tuple(names), np.array(lo), np.array(hi)

    @staticmethod
    def _amounts(gear) -> tuple:
        mg = getattr(gear, "modifications", None) or Microgeometry()
        return mg.theta_names

    def params(self, theta: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Both members' parameter vectors with the design ``theta`` [mm] set."""
        p = {"pinion": self.p0[0].copy(), "gear": self.p0[1].copy()}
        for n, t in zip(self.free, np.asarray(theta, float)):
            m, a = n.split(".", 1)
            p[m][self.tca.layout.member_names[m].index(member_entry(a))] = t
        return p["pinion"], p["gear"]


def member_entry(amount: str) -> str:
    """The member parameter of a free name: ``iso.<amount>`` for an ISO amount, the setting itself."""
    return amount if amount in SETTINGS else f"iso.{amount}"


def case_text(mis: Misalignment) -> str:
    """``"aligned"`` or the misalignment's non-zero kinds in the scene's units (``"crossing 2'"``)."""
    given = [f"{k} {Misalignment.display(k, getattr(mis, k))}" for k in Misalignment.names() if getattr(mis, k)]
    return ", ".join(given) or "aligned"
