"""Load capacity study (docs/rating.md): ISO 6336-1/-2/-3:2019 method B pitting and bending safety of
both members, with the face and transverse load factors from gearopt's loaded TCA (the pair's
micro-geometry and misalignment) and from ISO's method B, side by side.

Scene section ``[rating]``: ``torque`` (nominal pinion torque [N m], required), ``torques`` (the
torques rated, increasing; default 25 ... 150 % of ``torque``), the misalignment keys of ``[ltca]``,
and the options of :class:`gearopt.rating.settings.RatingSettings` (speed, life, materials, accuracy,
``load_factors = "ltca" | "iso"``: the set the safety factors use; ``fe_root = true``: the FE tooth-root
stress of both members beside ISO's sigma_F0, :mod:`gearopt.rating.fe_root`, CalculiX).

Outputs: results.json (docs/results.md, "rating"), ``rating_factors.csv`` (every factor at the
nominal torque, both sets), ``rating_vs_torque.csv``, ``rating_safety.png``.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Sequence

from ..summary import KeyNumber, rating_summary

if TYPE_CHECKING:  # pragma: no cover
    from ..gears import GearPair
    from ..meshing.misalignment import Misalignment
    from ..rating.settings import RatingSettings

UNITS = {"torque": "N m", "stress": "N/mm^2", "speed": "1/min", "life": "h", "deviation": "um",
         "line_load": "N/mm", "length": "mm", "angle": "rad", "factors": "-", "see": "docs/results.md"}
#: default torques as shares of the nominal torque
DEFAULT_SHARES = (0.25, 0.5, 0.75, 1.0, 1.25, 1.5)
#: the factors of the per-torque rows (both sets)
ROW_KEYS = ("K_v", "K_Hbeta", "K_Fbeta", "K_Halpha", "K_Falpha", "sigma_H", "sigma_F", "S_H", "S_F")


def _jsonable(v: Any) -> Any:
    if isinstance(v, tuple):
        return [float(x) for x in v]
    return v


class RatingReport:
    """Results of the rating study (``to_dict``, ``save_tables``, ``save_plots``)."""

    def __init__(self, data: dict) -> None:
        self.data = data

    def to_dict(self) -> dict:
        """The results.json dictionary (docs/results.md, "rating")."""
        return self.data

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "rating_safety.png": "Pitting (S_H) and bending (S_F) safety factors of both members against torque, solid "
                             "with gearopt's loaded-TCA load factors, dashed with ISO 6336-1's (left), and the two "
                             "methods' K_Hbeta and K_Halpha (right): read the torque at which a safety factor falls "
                             "below its minimum, and how far the two methods' load factors differ.",
        "rating_spectrum.png": "The S-N curves of pitting and bending with the load spectrum's bins on them (left) "
                               "and the Miner damage of each bin (right): read which bins consume the life.",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.rating_summary`), read from :meth:`to_dict`."""
        return rating_summary(self.data)

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """``rating_factors.csv`` (symbol, unit, both sets' pinion/pair and gear values at the nominal
        torque) and ``rating_vs_torque.csv`` (per torque: the load factors and safety factors of both sets)."""
        d = self.data
        used, iso = d["nominal"]["used"], d["nominal"]["iso"]
        units = d["nominal"]["units"]
        lines = ["symbol,unit,used_pinion_or_pair,used_gear,iso_pinion_or_pair,iso_gear"]

        def cells(v):
            if isinstance(v, list):
                return [_cell(v[0]), _cell(v[1])]
            return [_cell(v), ""]

        for k in used:
            lines.append(",".join([k, units.get(k, "-"), *cells(used[k]), *cells(iso.get(k))]))
        if "fe_root" in d:  # FE root stress (both columns of "used") beside ISO's sigma_F0, and the gap
            fe = d["fe_root"]["members"]
            lines.append(",".join(["sigma_F0_FE", "N/mm^2", _cell(fe[0]["sigma_FE"]), _cell(fe[1]["sigma_FE"]),
                                   _cell(fe[0]["sigma_F0_iso"]), _cell(fe[1]["sigma_F0_iso"])]))
            lines.append(",".join(["sigma_F0_FE_gap", "%", _cell(fe[0]["gap_pct"]), _cell(fe[1]["gap_pct"]), "", ""]))
        (Path(out_dir) / "rating_factors.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
        head = ["torque_Nm"]
        for k in ROW_KEYS:
            for src in ("used", "iso"):
                if k in ("sigma_H", "sigma_F", "S_H", "S_F"):
                    head += [f"{k}_pinion_{src}", f"{k}_gear_{src}"]
                else:
                    head.append(f"{k}_{src}")
        rows = [",".join(head)]
        u = d["load_factors_used"]
        for r in d["torques"]:
            row = [_cell(r["torque_Nm"])]
            for k in ROW_KEYS:
                for src in (u, "iso"):
                    v = r[k][src]
                    row += [_cell(v[0]), _cell(v[1])] if isinstance(v, list) else [_cell(v)]
            rows.append(",".join(row))
        (Path(out_dir) / "rating_vs_torque.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        files = ["rating_factors.csv", "rating_vs_torque.csv"]
        if "spectrum" in d:
            head = ["torque_Nm", "speed_rpm", "share", "hours", "cycles_pinion", "cycles_gear"]
            for mode, sym in (("pitting", "sigma_H"), ("bending", "sigma_F")):
                for m in ("pinion", "gear"):
                    head += [f"{sym}_{m}", f"N_{mode}_{m}", f"U_{mode}_{m}"]
            rows = [",".join(head)]
            for b in d["spectrum"]["bins"]:
                row = [b["torque_Nm"], b["speed_rpm"], b["share"], b["hours"], *b["cycles"]]
                for mode, sym in (("pitting", "sigma_H"), ("bending", "sigma_F")):
                    for i in range(2):
                        row += [b[sym][i], b[f"N_{mode}"][i], b[f"U_{mode}"][i]]
                rows.append(",".join(_cell(v) for v in row))
            (Path(out_dir) / "rating_spectrum.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
            files.append("rating_spectrum.csv")
        return files

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``rating_safety.png``: safety factors against torque (both load-factor sets) beside the
        load factors K_Hbeta, K_Halpha against torque."""
        import matplotlib.pyplot as plt

        from ..plot.rating import plot_load_factors, plot_safety_vs_torque
        from ..plot.saving import drawn_here
        from .ltca import save_figure

        out = Path(out_dir)
        mis = self.data.get("misalignment_text") or "aligned"
        # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
        files = ["rating_safety.png"]
        if drawn_here(out / "rating_safety.png"):
            fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), layout="constrained")
            plot_safety_vs_torque(self.data, ax=axes[0])
            plot_load_factors(self.data, ax=axes[1])
            save_figure(out, self.data["scene"], "rating_safety.png", fig, f"ISO 6336 load capacity ({mis})", dpi)
        if "spectrum" in self.data:
            files.append("rating_spectrum.png")
            if drawn_here(out / "rating_spectrum.png"):
                from ..plot.rating import plot_spectrum_damage, plot_spectrum_sn

                fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), layout="constrained")
                plot_spectrum_sn(self.data, ax=axes[0])
                plot_spectrum_damage(self.data, ax=axes[1])
                save_figure(out, self.data["scene"], "rating_spectrum.png", fig,
                            f"ISO 6336-6 load spectrum ({mis})", dpi)
        return files


def _cell(v: Any) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return f"{v:.10g}" if isinstance(v, float) else str(v)


class RatingStudy:
    """ISO 6336 rating of a pair at a list of torques, with the load factors of the loaded TCA and of ISO.

    Parameters
    ----------
    pair : GearPair
    torque : float
        Nominal pinion torque [N m] (> 0).
    torques : sequence of float, optional
        Torques rated [N m], strictly increasing (default 25 ... 150 % of ``torque``).
    misalignment : Misalignment, optional
        The drive's misalignment for the loaded TCA (ISO's K_Hbeta takes ``f_ma``, ``f_sh``).
    name : str
    settings : RatingSettings, optional
        Options (:class:`gearopt.rating.settings.RatingSettings`); keyword arguments replace its fields.
    """

    def __init__(self, pair: GearPair, torque: float, torques: Sequence[float] | None = None,
                 misalignment: Misalignment | None = None, name: str = "rating",
                 settings: RatingSettings | None = None, **options: Any) -> None:
        from ..errors import OptionError, check_number, out_of_range
        from ..meshing.misalignment import Misalignment
        from ..rating.materials import material
        from ..rating.pair import pair_data
        from ..rating.settings import RatingSettings

        s = RatingSettings.of(settings, **options)
        torque = check_number("torque", torque, "the nominal pinion torque [N m]", cls=OptionError)
        if not torque > 0:
            raise out_of_range("torque", torque, "torque > 0 N m (nominal pinion torque)", cls=OptionError)
        torques = [s_ * torque for s_ in DEFAULT_SHARES] if torques is None else [float(t) for t in torques]
        if any(not t > 0 for t in torques) or any(b <= a for a, b in zip(torques, torques[1:])):
            raise out_of_range("torques", torques, "a strictly increasing list of torques > 0 N m", cls=OptionError)
        self.pair, self.torque, self.torques, self.name, self.settings = pair, torque, torques, name, s
        self.misalignment = misalignment or Misalignment()
        self.misalignment.check(pair, "misalignment")
        self.pair_data = pair_data(pair)
        self.materials = (material(s.pinion_material, s.pinion_grade, s.pinion_sigma_Hlim, s.pinion_sigma_Flim,
                                   "pinion_material"),
                          material(s.gear_material, s.gear_grade, s.gear_sigma_Hlim, s.gear_sigma_Flim,
                                   "gear_material"))
        self.bins = spectrum_bins(s)
        if s.f_ma is None:
            from ..rating.iso6336 import geometry
            from ..rating.pair import mesh_misalignment

            m = self.misalignment
            self.f_ma = mesh_misalignment(self.pair_data.b, geometry(self.pair_data).alpha_wt, m.crossing,
                                          m.intersecting)
            self.f_ma_source = "misalignment"
        else:
            self.f_ma, self.f_ma_source = s.f_ma, "given"
        from ..rating.pair import generated_tooth_forms

        self.tooth_forms = generated_tooth_forms(pair, self.pair_data) if s.tooth_form == "generated" else None
        if s.fe_root:
            check_fe_root(pair)
        # the ISO rating at every torque now: a pair ISO 6336 cannot rate is refused before the LTCA runs
        self.iso = [self.rate(t) for t in self.torques]
        self.iso_nominal = self.rate(self.torque)

    def operation(self, torque: float, K_Hbeta: float | None = None, K_Halpha: float | None = None) -> Any:
        """The :class:`~gearopt.rating.iso6336.Operation` at ``torque`` [N m]."""
        from ..rating.iso6336 import Operation

        s = self.settings
        return Operation(T1=torque, n1=s.speed, K_A=s.K_A, L_h=s.life, nu40=s.nu40, R_z1=s.rz_flank, R_z2=s.rz_flank,
                         R_zF1=s.rz_root, R_zF2=s.rz_root, S_Hmin=s.S_Hmin, S_Fmin=s.S_Fmin, y_lim=s.y_lim,
                         Y_beta_edition=s.y_beta_edition,
                         K_Hbeta=K_Hbeta, K_Halpha=K_Halpha)

    def accuracy(self) -> Any:
        """The :class:`~gearopt.rating.iso6336.Accuracy` of the options."""
        from ..rating.iso6336 import Accuracy

        return Accuracy(f_pb=self.settings.f_pb, f_falpha=self.settings.f_falpha, f_ma=self.f_ma,
                        f_sh=self.settings.f_sh, C_a=self.settings.tip_relief, grade=self.settings.accuracy_grade)

    def rate(self, torque: float, K_Hbeta: float | None = None, K_Halpha: float | None = None) -> Any:
        """The :class:`~gearopt.rating.iso6336.Rating` at ``torque`` [N m] (ISO's load factors unless given)."""
        from ..rating.iso6336 import rate

        return rate(self.pair_data, self.operation(torque, K_Hbeta, K_Halpha), *self.materials, self.accuracy(),
                    self.tooth_forms)

    def tooth_form_report(self) -> dict:
        """The critical root sections used (``source``) and both kinds per member: measured on the
        generated teeth (None for a helical pair or ``tooth_form = "iso"``) and ISO's closed form."""
        from ..rating.iso6336 import form_factors, geometry, tooth_form

        p = self.pair_data
        g = geometry(p)
        keys = ("s_Fn", "h_Fe", "rho_F", "alpha_Fen", "Y_F", "Y_S")
        closed = [{k: tooth_form(i, p, g)[k] for k in keys} for i in range(2)]
        gen = None
        if self.tooth_forms is not None:
            gen = [{k: v for k, v in form_factors(t["s_Fn"], t["h_Fe"], t["rho_F"], t["alpha_Fen"], p.m_n,
                                                  p.alpha_n).items() if k in keys} for t in self.tooth_forms]
        return {"source": "generated tooth" if gen is not None else "ISO 6336-3 method B closed form",
                "generated": gen, "closed_form": closed}

    def run(self, progress: Callable[[str], None] | None = None) -> RatingReport:
        from ..plot.tca import misalignment_text
        from ..rating.pair import ltca_load_factors
        from ..report import misalignment_dict

        t0 = time.perf_counter()
        s = self.settings
        all_t = sorted(set(self.torques) | {self.torque} | {b.T for b in self.bins})
        lf = ltca_load_factors(self.pair, all_t, self.misalignment, s, progress)
        by_t = {t: i for i, t in enumerate(all_t)}
        lt = {t: self.rate(t, lf["K_Hbeta"][by_t[t]], lf["K_Halpha"][by_t[t]]) for t in all_t}
        used = s.load_factors
        rows = []
        for t, ri in zip(self.torques, self.iso):
            rl = lt[t]
            row: dict = {"torque_Nm": t}
            for k in ROW_KEYS:
                row[k] = {"iso": _jsonable(ri[k]), "ltca": _jsonable(rl[k])}
            i = by_t[t]
            row["K_Halpha_ltca_raw"] = lf["K_Halpha_raw"][i]
            row["K_Hbeta_ltca_line"] = lf["K_Hbeta_line"][i]
            row["w_face_N_per_mm"] = lf["w_face_N_per_mm"][i]
            row["w_pair_max_N_per_mm"] = lf["w_pair_max_N_per_mm"][i]
            row["w_pair_max_reference_N_per_mm"] = lf["w_pair_max_reference_N_per_mm"][i]
            rows.append(row)
        nom_l, nom_i = lt[self.torque], self.iso_nominal
        chosen = nom_l if used == "ltca" else nom_i
        mis = misalignment_dict(self.misalignment)
        p = self.pair_data
        m1, m2 = self.materials
        data = {
            "study": "rating", "scene": self.name, "units": UNITS, "standard": "ISO 6336-1/-2/-3:2019 method B",
            "options": s.to_dict(), "load_factors_used": used, "f_ma_um": self.f_ma, "f_ma_source": self.f_ma_source,
            "pair": {"z1": p.z1, "z2": p.z2, "m_n": p.m_n, "alpha_n": p.alpha_n, "beta": p.beta, "b": p.b,
                     "x1": p.x1, "x2": p.x2, "a": p.a, "h_fP": p.h_fP, "rho_fP": p.rho_fP},
            "materials": [{"member": mem, "group": m.group.key, "grade": m.grade, "sigma_Hlim": m.sigma_Hlim,
                           "sigma_Flim": m.sigma_Flim, "source": m.group.note} for mem, m in (("pinion", m1), ("gear", m2))],
            "misalignment": mis, "misalignment_text": misalignment_text({"misalignment": mis}),
            "z_face_mm": lf["z_face_mm"], "torques": rows, "tooth_form": self.tooth_form_report(),
            "nominal": {"torque_Nm": self.torque,
                        "used": {k: _jsonable(v) for k, v in chosen.values.items()},
                        "iso": {k: _jsonable(v) for k, v in nom_i.values.items()},
                        "ltca": {k: _jsonable(v) for k, v in nom_l.values.items()},
                        "units": dict(chosen.units), "sources": dict(chosen.sources)},
            "timing": {"run_s": time.perf_counter() - t0},
        }
        if s.fe_root:
            from ..rating.fe_root import fe_root_stress
            from ..rating.iso6336 import geometry, tooth_form

            g = geometry(p)
            d_en = (tooth_form(0, p, g)["d_en"], tooth_form(1, p, g)["d_en"])
            data["fe_root"] = fe_root_stress(self.pair, self.torque, d_en, nom_i["sigma_F0"], progress)
            data["timing"]["fe_root_s"] = data["fe_root"]["run_s"]
            data["timing"]["run_s"] = time.perf_counter() - t0
        if self.bins:
            from ..rating.spectrum import rate_spectrum

            given = {t: (lf["K_Hbeta"][by_t[t]], lf["K_Halpha"][by_t[t]]) for t in all_t} if used == "ltca" else None
            sp = rate_spectrum(self.pair_data, self.bins, self.operation(self.torque), *self.materials,
                               self.accuracy(), load_factors=given, tooth_forms=self.tooth_forms)
            data["spectrum"] = sp
        return RatingReport(data)


def check_fe_root(pair: GearPair) -> None:
    """Before any run: ``fe_root = true`` needs CalculiX and a spur pair (an OptionError naming the key)."""
    from ..errors import OptionError
    from ..fea.calculix import CCX_ENV, ccx_path
    from ..rating.fe_root import require_spur

    require_spur(pair)
    if ccx_path() is None:
        raise OptionError(f"fe_root = true needs CalculiX (ccx), which is not installed or not on PATH. Install it "
                          f"(Debian/Ubuntu: apt-get install calculix-ccx; `make ccx`), set {CCX_ENV} to the executable, "
                          "or set fe_root = false.", param="fe_root", value=True,
                          valid="false without CalculiX")


def spectrum_bins(s: Any) -> list:
    """The load spectrum of the options as :class:`gearopt.rating.spectrum.Bin` objects ([] without one).

    Raises
    ------
    OptionError
        Only some of ``spectrum_torque``, ``spectrum_speed``, ``spectrum_share`` given, lists of different
        lengths, or bins that :func:`gearopt.rating.spectrum.check_bins` refuses (shares not adding up to 1).
    """
    from ..errors import OptionError
    from ..rating.spectrum import Bin, check_bins

    lists = {"spectrum_torque": s.spectrum_torque, "spectrum_speed": s.spectrum_speed,
             "spectrum_share": s.spectrum_share}
    given = [k for k, v in lists.items() if v is not None]
    if not given:
        return []
    if len(given) < 3 or len({len(v) for v in lists.values()}) != 1:
        missing = [k for k in lists if k not in given]
        key = missing[0] if missing else "spectrum_share"
        raise OptionError(f"{key} = {lists[key]!r}: a load spectrum needs spectrum_torque, spectrum_speed and "
                          "spectrum_share, lists of the same length (one entry per bin).", param=key,
                          value=lists[key], valid="three lists of the same length")
    bins = [Bin(float(t), float(n), float(w)) for t, n, w in zip(*lists.values())]
    check_bins(bins)
    return bins


def _from_scene(scene: Any) -> RatingStudy:
    from ..errors import GeometryError, OptionError
    from ..rating.settings import RatingSettings
    from .tca import check_misalignment_keys, misalignment_from

    o = scene.options.get("rating", {}) or {}
    check_misalignment_keys(scene, "rating", o, signs=(1,))
    try:
        return RatingStudy(scene.pair, o["torque"], torques=o.get("torques"), misalignment=misalignment_from(o),
                           name=scene.name, settings=RatingSettings.from_scene(o))
    except (GeometryError, OptionError) as e:
        raise scene.study_error("rating", e) from e


def _register() -> None:
    from ..rating.settings import RatingSettings
    from . import StudySpec, register
    from .ltca import torque_fields
    from .tca import misalignment_fields

    keys = [k for k, (o, _) in RatingSettings.options().items() if o.key != ""]  # the scene keys (not curvature, ...)
    register(StudySpec(
        name="rating",
        doc="ISO 6336 pitting and bending safety, with K_Hbeta and K_Halpha from the loaded TCA beside ISO's",
        sections=[RatingSettings.section("rating", [
            *torque_fields("the factor table", "pinion torques rated (default 25 ... 150 % of torque)"),
            *keys,
            *misalignment_fields(),
        ], required=True)],
        settings=(RatingSettings,),
        build=_from_scene,
    ))


_register()
