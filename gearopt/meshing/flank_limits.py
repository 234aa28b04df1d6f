"""Where the generated flanks of a tooth contact analysis end: the flank limit (the tool's
flank/fillet junction, or a fold of an undercut flank) of either member per face section, its table
in z^2, the test whether solved contact points lie on the real flank, and the report of folded flanks.
:class:`FlankLimits` is a part of :class:`gearopt.meshing.tca.TCA`."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from ..geometry.generation import FlankLimit


class FlankLimits:
    """The flank-limit methods of :class:`~gearopt.meshing.tca.TCA` (a mixin: they use its ``pair``,
    ``side``, ``pinion``, ``gear``, ``layout`` and its memo of limits ``_limits``)."""

    def form_radius(self, member: int, p: npt.ArrayLike | None = None) -> float:
        """Form radius [mm] of member 1 (pinion) or 2 (gear) on the driving flank in the mid section
        z = 0, for the parameter vector ``p`` (default: as built): where the real generated flank
        ends (:meth:`GeneratedTooth.flank_limit`: the tool's flank/fillet junction, or below a fold
        of the flank its crossing with the reversed branch or the fillet)."""
        return self.flank_limit(member, 0.0, p).radius

    def flank_limit(self, member: int, z: float = 0.0, p: npt.ArrayLike | None = None) -> FlankLimit:
        """:class:`~gearopt.geometry.generation.FlankLimit` of member 1 (pinion) or 2 (gear) on the
        driving side in section ``z`` [mm] for the parameter vector ``p`` (default: as built)."""
        tooth = self.pinion if member == 1 else self.gear
        p = tooth.p0 if p is None else np.asarray(p, float).ravel()
        key = ("limit", member, float(z), tuple(p.tolist()))
        if key not in self._limits:
            self._limits[key] = tooth.flank_limit(self.side, float(z), p)
        return self._limits[key]

    def limit_table(self, member: int, p: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(z^2 grid, u_limit on it): the flank limit depends on z only through the plunging a_pl z^2
        (a shift of the tool in that section), so it is tabulated in z^2 across the face."""
        tooth = self.pinion if member == 1 else self.gear
        p = tooth.p0 if p is None else np.asarray(p, float).ravel()
        key = ("table", member, tuple(p.tolist()))
        if key not in self._limits:
            b = (self.pair.pinion if member == 1 else self.pair.gear).b
            a_pl = p[self.layout.p_index("pinion" if member == 1 else "gear", "a_pl")]
            s = np.array([0.0]) if a_pl == 0 else (b / 2) ** 2 * np.linspace(0.0, 1.0, 9)
            ends = [self.flank_limit(member, math.sqrt(v), p) for v in (s[0], s[-1])]
            if all(e.kind == "junction" for e in ends) and ends[0].u == ends[1].u:
                # The plunging shifts the tool monotonically in z^2, and a fold (undercut) grows with
                # the shift: regular at both ends means regular in between, and the flank ends at
                # the tool's junction, the same u in every section (checked: tests/test_flank_limit.py).
                s = s[:1]
            self._limits[key] = (s, np.array([self.flank_limit(member, math.sqrt(v), p).u for v in s]))
        return self._limits[key]

    def on_flank(self, member: int, u: npt.ArrayLike, z: npt.ArrayLike, p: npt.ArrayLike | None = None,
                 band: float = 1e-3) -> np.ndarray:
        """True where the flank point (u, z) [mm] of member 1 or 2 lies on the real generated flank
        (``u`` not past the flank limit of its section; the tip and face are checked elsewhere).
        The limit is interpolated in z^2 (:meth:`limit_table`) and recomputed exactly for points
        within ``band`` [mm] of it or within the limit's change across their table interval (the
        interpolation's error bound: the limit moves monotonically with the plunging shift).
        NaN points are False."""
        u, z = np.asarray(u, float), np.asarray(z, float)
        s_grid, u_grid = self.limit_table(member, p)
        fin = np.isfinite(u) & np.isfinite(z)
        if s_grid.size == 1:  # one limit in every section (compared where finite only)
            return np.less_equal(u, u_grid[0] + 1e-8, out=np.zeros(u.shape, bool), where=fin)
        b = (self.pair.pinion if member == 1 else self.pair.gear).b
        s = np.clip(np.where(fin, z, 0.0) ** 2, 0.0, (b / 2) ** 2)
        u_lim = np.interp(s, s_grid, u_grid) if s_grid.size > 1 else np.full(u.shape, u_grid[0])
        if s_grid.size > 1:  # within the table interval's own variation of the limit (the
            # interpolation's error bound), or within band of it: the exact limit of that section
            k = np.clip(np.searchsorted(s_grid, s, side="right") - 1, 0, s_grid.size - 2)
            width = np.maximum(band, np.abs(np.diff(u_grid))[k])
            near = fin & (np.abs(np.where(fin, u, 0.0) - u_lim) < width)
        else:
            near = np.zeros(u.shape, bool)
        for idx in zip(*np.nonzero(near)):
            u_lim[idx] = self.flank_limit(member, math.sqrt(s[idx]), p).u
        with np.errstate(invalid="ignore"):
            return fin & (u <= u_lim + 1e-8)

    on_active_flank = on_flank  #: (the old name)

    def folding(self, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None) -> dict:
        """Members whose driving flank folds before the tool's junction (mid section), with the
        flank limit and the largest a_c that does not fold: ``{"pinion": {...}}``; empty if none."""
        out = {}
        for member, name, tooth, p in ((1, "pinion", self.pinion, p1), (2, "gear", self.gear, p2)):
            lim = self.flank_limit(member, 0.0, p)
            if lim.folded:
                key = ("a_c_max", member, tuple((tooth.p0 if p is None else np.asarray(p, float)).tolist()))
                if key not in self._limits:
                    self._limits[key] = float(tooth.max_unfolded_a_c(self.side, 0.0, p))
                out[name] = {"kind": lim.kind, "r_form": float(lim.radius), "u_limit": float(lim.u),
                             "r_fold": float(lim.radius_fold),
                             "r_junction": float(np.hypot(*tooth.point(self.side, "flank", lim.u_junction, 0.0,
                                                                       p)[0][:2])),
                             "a_c": float((tooth.p0 if p is None else np.asarray(p, float))[
                                 self.layout.p_index(name, "a_c")]),
                             "a_c_max_unfolded": self._limits[key]}
        return out
