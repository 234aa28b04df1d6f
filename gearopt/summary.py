"""The key numbers of a run: the small top-level ``summary`` of results.json and the first table of
``report.html`` (docs/results.md, "summary").

A key number is one scalar a gear engineer reads first (a contact ratio, the peak-to-peak TE of a
case, the peak pressure at a torque, a Monte Carlo percentile), with a stable ``key``, a label, its
unit and which direction is better. Every study's result object has ``summary() -> list[KeyNumber]``;
each is computed here from the result's own dictionary (``to_dict()``, what results.json holds), so
that the summary repeats numbers of the file and never computes new ones. A quantity a study does
not have is absent from its summary (never 0); ``value`` is ``None`` only where the quantity exists
but has no value (e.g. harmonics of a TE that does not span whole mesh cycles).

Keys are ``<quantity>_<unit>`` with the case, torque, member or statistic in brackets:
``te_pp_arcsec[aligned]``, ``p_max_MPa[200 Nm]``, ``mc_te_pp_arcsec[p95]``. This module imports
nothing of gearopt (base layer); it reads plain dictionaries, so it also summarises a results.json
read back from disk (:func:`summarize`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Callable, Literal

__all__ = ["KeyNumber", "GROUPS", "summarize", "summary_dicts", "summary_from_results", "format_value", "with_pair",
           "SUMMARIES", "tca_summary", "geometry_summary", "planar_tca_summary", "ltca_summary", "crowning_summary",
           "fea_summary", "loaded_microgeometry_summary", "robust_summary"]

#: The groups of key numbers, in the order the report shows them.
GROUPS = ("geometry", "inspection", "optimisation", "unloaded TE", "loaded", "rating", "dynamics", "FE", "Monte Carlo",
          "sweep")

Value = float | int | str | bool | None


@dataclass(frozen=True)
class KeyNumber:
    """One key number of a run.

    Parameters
    ----------
    key : str
        Stable identifier, ``<quantity>_<unit>`` with an optional ``[<case>]`` (``te_pp_arcsec[aligned]``);
        the same quantity has the same key in every study and every run (docs/results.md, "summary").
    label : str
        Human-readable name, without the unit (``"TE peak-to-peak, aligned"``).
    value : float, int, str, bool or None
        The number as results.json holds it (unit ``unit``); ``None``: the quantity exists for this run
        but has no value.
    unit : str
        Unit of ``value`` (``"arcsec"``, ``"mm"``, ``"MPa"``; ``""`` for a pure number).
    better : {"lower", "higher"} or None
        Which direction is better when two designs are compared; ``None`` where neither is.
    group : str
        One of :data:`GROUPS`.
    """

    key: str
    label: str
    value: Value
    unit: str = ""
    better: Literal["lower", "higher"] | None = None
    group: str = "geometry"

    def __post_init__(self) -> None:
        if self.better not in (None, "lower", "higher"):
            raise ValueError(f"KeyNumber {self.key!r}: better = {self.better!r}; valid: 'lower', 'higher' or None")
        if self.group not in GROUPS:
            raise ValueError(f"KeyNumber {self.key!r}: group = {self.group!r}; valid: {', '.join(GROUPS)}")
        if isinstance(self.value, float) and not math.isfinite(self.value):
            raise ValueError(f"KeyNumber {self.key!r}: value = {self.value!r} is not finite; use None for no value")

    def to_dict(self) -> dict[str, Any]:
        """The entry of results.json's ``summary``: ``{key, label, value, unit, better, group}``."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> KeyNumber:
        """A key number from an entry of results.json's ``summary``."""
        return cls(key=d["key"], label=d["label"], value=d["value"], unit=d.get("unit", ""),
                   better=d.get("better"), group=d.get("group", "geometry"))

    def formatted(self, digits: int = 4) -> str:
        """``value`` for a table (:func:`format_value`), without the unit."""
        return format_value(self.value, digits)


def format_value(v: Value, digits: int = 4) -> str:
    """A key number's value as text: ``digits`` significant digits for floats (a float below 1e-9 in
    magnitude, round-off of a zero such as the backlash of a zero-backlash pair, as ``0``), integers
    as they are, ``yes``/``no`` for booleans and an em dash for ``None`` (no value)."""
    if v is None:
        return "\u2014"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if abs(v) < 1e-9:
            return "0"
        text = f"{v:.{digits}g}"
        return text.replace("e+0", "e").replace("e-0", "e-")
    return str(v)


def summary_dicts(numbers: list[KeyNumber]) -> list[dict[str, Any]]:
    """The ``summary`` list of results.json (one dictionary per key number, in order)."""
    keys = [n.key for n in numbers]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ValueError(f"summary: duplicate keys {dup}")
    return [n.to_dict() for n in numbers]


def summary_from_results(data: dict[str, Any]) -> list[KeyNumber]:
    """The key numbers of a results.json read back: its ``summary`` when it has one, else computed
    from its arrays (:func:`summarize`; a results.json of an earlier gearopt)."""
    if isinstance(data.get("summary"), list):
        return [KeyNumber.from_dict(d) for d in data["summary"]]
    return summarize(data)


def summarize(data: dict[str, Any]) -> list[KeyNumber]:
    """The key numbers of a study's result dictionary (``to_dict()`` or results.json), by its
    ``study``; ``[]`` for a study without a summary function in :data:`SUMMARIES`."""
    fn = SUMMARIES.get(data.get("study", ""))
    return with_pair(fn(data) if fn is not None else [], data)


# --- helpers --------------------------------------------------------------------------------------
def _num(v: Any) -> Value:
    """A JSON scalar as a key-number value (ints stay ints; anything else not a scalar: None)."""
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if hasattr(v, "item"):  # NumPy scalar
        return _num(v.item())
    return None


def _torque_label(t: float) -> str:
    return f"{t:g} Nm"


def _pair_geometry(p: dict, eps_gamma: bool = False) -> list[KeyNumber]:
    """Geometry key numbers of a ``pair`` dictionary holding ``z1``, ``z2``, ``m_n``... (tca, ltca)."""
    out = []
    rows = [("z1", "z1", "pinion teeth z1", ""), ("z2", "z2", "gear teeth z2", ""),
            ("m_n", "m_n_mm", "normal module m_n", "mm"), ("beta_deg", "beta_deg", "helix angle beta", "deg"),
            ("a", "a_mm", "centre distance a", "mm"), ("ratio", "ratio", "gear ratio z2/z1", "")]
    for src, key, label, unit in rows:
        if src in p:
            out.append(KeyNumber(key, label, _num(p[src]), unit, None, "geometry"))
    for src, key, label in (("eps_alpha", "eps_alpha", "transverse contact ratio eps_alpha"),
                            ("eps_beta", "eps_beta", "overlap ratio eps_beta"),
                            ("eps_gamma", "eps_gamma", "total contact ratio eps_gamma")):
        if src in p:
            out.append(KeyNumber(key, label, _num(p[src]), "", "higher", "geometry"))
    if "backlash_circumferential" in p:
        out.append(KeyNumber("backlash_circumferential_mm", "circumferential backlash j_wt (smallest)",
                             _num(p["backlash_circumferential"]), "mm", None, "geometry"))
    if isinstance(p.get("side"), str):
        out.append(KeyNumber("side", "driving flank of the pinion", p["side"], "", None, "geometry"))
    out += _crowning_settings(p.get("pinion_a_c"), p.get("pinion_a_pl"))
    iso = p.get("pinion_iso_um")
    if isinstance(iso, dict):
        out += _iso_amounts(iso)
    return out


def _iso_amounts(iso: dict) -> list[KeyNumber]:
    """The pinion's crowning in ISO 21771 terms [um] (``C_alpha``, ``f_H_alpha``, ``C_beta``, ``f_H_beta``)."""
    return [KeyNumber(f"{k}_um[pinion]", f"pinion {k} (ISO 21771 terms)", _num(v), "um", None, "geometry")
            for k, v in iso.items()]


def with_pair(numbers: list[KeyNumber], data: dict[str, Any]) -> list[KeyNumber]:
    """``numbers`` with the pair's ``z1``, ``z2``, ``m_n_mm``, ``beta_deg``, ``a_mm`` and ``side``
    from results.json's ``meta.pair`` (written by :func:`gearopt.io.results.write_results` from the
    scene) put in front where the study's own numbers lack them (the crowning, loaded micro-geometry
    and robust results hold no pair block)."""
    mp = (data.get("meta") or {}).get("pair")
    if not isinstance(mp, dict):
        return list(numbers)
    have = {n.key for n in numbers}
    extra = [n for n in _pair_geometry({k: v for k, v in mp.items() if k in ("z1", "z2", "m_n", "beta_deg", "a", "side")})
             if n.key not in have]
    return extra + list(numbers)


def _crowning_settings(a_c: Any, a_pl: Any) -> list[KeyNumber]:
    """The pinion's crowning settings (Litvin's parabola coefficients a_c, a_pl [1/mm]) where given."""
    out = []
    if a_c is not None:
        out.append(KeyNumber("pinion_a_c_per_mm", "pinion profile crowning a_c", _num(a_c), "1/mm", None, "geometry"))
    if a_pl is not None:
        out.append(KeyNumber("pinion_a_pl_per_mm", "pinion lead crowning a_pl", _num(a_pl), "1/mm", None,
                             "geometry"))
    return out


def _harmonics(h: list | None, n: int = 3) -> list[Value]:
    return [None] * n if h is None else [_num(h[i]) if i < len(h) else None for i in range(n)]


def _tca_cases(cases: list[dict], prefix: str = "", label_prefix: str = "") -> list[KeyNumber]:
    """Unloaded TE per case of a tca ``cases`` list: peak-to-peak, first three harmonics, edge contact."""
    out = []
    for c in cases:
        lab = c["label"]
        out.append(KeyNumber(f"{prefix}te_pp_arcsec[{lab}]", f"{label_prefix}TE peak-to-peak, {lab}",
                             _num(c["peak_to_peak_arcsec"]), "arcsec", "lower", "unloaded TE"))
        for i, v in enumerate(_harmonics(c.get("harmonics_arcsec")), start=1):
            out.append(KeyNumber(f"{prefix}te_h{i}_arcsec[{lab}]", f"{label_prefix}TE harmonic {i} (mesh order {i}), {lab}",
                                 v, "arcsec", "lower", "unloaded TE"))
        if c.get("edge_analysis"):
            out.append(KeyNumber(f"{prefix}edge_contact[{lab}]", f"{label_prefix}an edge carries load, {lab}",
                                 bool(c["edge_carries_load"]), "", "lower", "unloaded TE"))
    return out


# --- per study ------------------------------------------------------------------------------------
#: The ISO 1328-1 chart values of an inspected flank in the summary: (name, label, better).
_CHARTS = (("F_alpha", "profile total deviation F_alpha", "lower"), ("f_f_alpha", "profile form deviation f_f_alpha",
           "lower"), ("f_H_alpha", "profile slope deviation f_H_alpha", None), ("C_alpha", "profile crowning C_alpha",
           None), ("F_beta", "helix total deviation F_beta", "lower"), ("f_f_beta", "helix form deviation f_f_beta",
           "lower"), ("f_H_beta", "helix slope deviation f_H_beta", None), ("C_beta", "lead crowning C_beta", None))


def _inspection(ins: dict) -> list[KeyNumber]:
    """Chart values [um] of every inspected flank (``inspection.<member>.<side>.charts_um``)."""
    out = []
    for name, label, better in _CHARTS:
        for member, sides in ins.items():
            for side, v in sides.items():
                charts = v.get("charts_um") or {}
                if name in charts:
                    out.append(KeyNumber(f"chart_{name}_um[{member} {side}]", f"{label}, {member} {side}",
                                         _num(charts[name]), "um", better, "inspection"))
    return out


def tca_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """tca: the pair's geometry (z, m_n, beta, a, contact ratios, backlash, the pinion's crowning),
    the chart values of inspected flanks, and per case the TE peak-to-peak, its first three mesh
    harmonics and, with edge contact, whether an edge carries load."""
    return _pair_geometry(d["pair"]) + _inspection(d.get("inspection") or {}) + _tca_cases(d["cases"])


def geometry_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """geometry: z, m_n, beta, a, contact ratios, backlash, tip clearances and per member the form
    margin, the undercut margin and the tip thickness."""
    p, m = d["pair"], d["members"]
    pair = {"z1": m["pinion"]["z"], "z2": m["gear"]["z"], "m_n": m["pinion"]["m_n"],
            "beta_deg": m["pinion"]["beta_deg"], **p}
    out = _pair_geometry(pair)
    if "backlash_circumferential_max" in p:
        out.append(KeyNumber("backlash_circumferential_max_mm", "circumferential backlash j_wt (largest)",
                             _num(p["backlash_circumferential_max"]), "mm", None, "geometry"))
    for member, key in (("pinion", "tip_clearance_pinion"), ("gear", "tip_clearance_gear")):
        if key in p:
            out.append(KeyNumber(f"tip_clearance_mm[{member}]", f"tip clearance, {member}", _num(p[key]),
                                 "mm", "higher", "geometry"))
    for member in ("pinion", "gear"):
        g = m[member]
        if "form_margin" in g:
            out.append(KeyNumber(f"form_margin_mm[{member}]", f"form margin r_active_start - r_form, {member}",
                                 _num(g["form_margin"]), "mm", "higher", "geometry"))
        if "undercut_margin_x" in g:
            out.append(KeyNumber(f"undercut_margin_x[{member}]", f"undercut margin x - x_min, {member}",
                                 _num(g["undercut_margin_x"]), "", "higher", "geometry"))
        if "s_a_over_m_n" in g:
            out.append(KeyNumber(f"s_a_over_m_n[{member}]", f"tip thickness s_a / m_n, {member}",
                                 _num(g["s_a_over_m_n"]), "", "higher", "geometry"))
    return out


def planar_tca_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """planar_tca: the ratio m12, the largest |TE| and the line of action's angle."""
    dv = d["derived"]
    out = [KeyNumber("m12", "gear ratio m12 = dphi1/dphi2", _num(dv["m12"]), "", None, "geometry"),
           KeyNumber("te_max_abs_arcsec", "largest |TE|", _num(dv["te_max_abs_arcsec"]), "arcsec", "lower",
                     "unloaded TE")]
    loa = dv.get("line_of_action") or {}
    if "angle_deg" in loa:
        out.append(KeyNumber("line_of_action_angle_deg", "angle of the line of action", _num(loa["angle_deg"]),
                             "deg", None, "geometry"))
    return out


def ltca_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """ltca: geometry; the unloaded TE; per torque the loaded TE peak-to-peak, the peak contact
    pressure and the largest share of the load carried at an edge; at the nominal torque the
    mesh stiffness c_gamma and K_Hbeta."""
    out = _pair_geometry(d["pair"])
    out.append(KeyNumber("te_pp_arcsec[unloaded]", "TE peak-to-peak, unloaded", _num(d["unloaded_peak_to_peak_arcsec"]),
                         "arcsec", "lower", "unloaded TE"))
    return out + _ltca_torques(d)


def _ltca_torques(d: dict[str, Any], prefix: str = "", label_prefix: str = "") -> list[KeyNumber]:
    out = []
    torques = d["torques"]
    for t in torques:
        lab = _torque_label(t["torque_Nm"])
        out.append(KeyNumber(f"{prefix}lte_pp_arcsec[{lab}]", f"{label_prefix}loaded TE peak-to-peak, {lab}",
                             _num(t["peak_to_peak_arcsec"]), "arcsec", "lower", "loaded"))
    for t in torques:
        lab = _torque_label(t["torque_Nm"])
        out.append(KeyNumber(f"{prefix}p_max_MPa[{lab}]", f"{label_prefix}peak contact pressure, {lab}",
                             _num(t["p_max_MPa"]), "MPa", "lower", "loaded"))
    for t in torques:
        lab = _torque_label(t["torque_Nm"])
        out.append(KeyNumber(f"{prefix}edge_share_max[{lab}]",
                             f"{label_prefix}largest share of the load at an edge, {lab}",
                             _num(t["edge_share_max"]), "", "lower", "loaded"))
    nominal = d.get("nominal_torque_Nm")
    nom = [t for t in torques if t["torque_Nm"] == nominal]
    if nom:
        t, lab = nom[0], _torque_label(nominal)
        out.append(KeyNumber(f"{prefix}c_gamma_N_per_mm_um[{lab}]", f"{label_prefix}mesh stiffness c_gamma, {lab}",
                             _num(t["c_gamma_N_per_mm_um"]), "N/(mm um)", None, "loaded"))
        out.append(KeyNumber(f"{prefix}K_Hbeta[{lab}]", f"{label_prefix}face load factor K_Hbeta, {lab}",
                             _num(t["K_Hbeta"]), "", "lower", "loaded"))
    return out


def crowning_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """crowning: the optimised settings (a_c, a_pl and in ISO terms), IPOPT's status and objective,
    the verified TE level per case, and the unloaded TE of every case after the optimisation
    (plain keys, as the tca study's) and before it (``before.`` keys)."""
    de = d["design"]
    st = de.get("settings") or {}
    out = _crowning_settings(st.get("a_c"), st.get("a_pl"))
    out += _iso_amounts(de.get("iso_um") or {})
    out.append(KeyNumber("status", "optimiser status", _num(de.get("status")), "", None, "optimisation"))
    out.append(KeyNumber("objective", "optimiser objective (misfit to the target TE)", _num(de.get("objective")), "",
                         "lower", "optimisation"))
    if de.get("target_te_level_arcsec") is not None:
        out.append(KeyNumber("target_te_level_arcsec", "target TE level", _num(de["target_te_level_arcsec"]),
                             "arcsec", None, "optimisation"))
    for c in de.get("cases") or []:
        out.append(KeyNumber(f"te_level_arcsec[{c['name']}]", f"verified TE level, {c['name']}",
                             _num(c["te_level_arcsec"]), "arcsec", None, "optimisation"))
    return out + _tca_cases(d["after"]) + _tca_cases(d["before"], "before.", "before: ")


def _position_label(phi1: float) -> str:
    return f"phi1 {math.degrees(phi1):.4g} deg"


def fea_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """fea: the drive and per position the loaded TE, the largest contact pressure, its ratio to
    Hertz and the largest principal root stress at mid face of each member."""
    out = _pair_geometry(d["pair"])
    for p in d["positions"]:
        pos = _position_label(p["phi1"])
        out.append(KeyNumber(f"fe_loaded_te_arcsec[{pos}]", f"FE loaded TE, {pos}", _num(p.get("loaded_te_arcsec")),
                             "arcsec", None, "FE"))
        c = p.get("contact") or {}
        out.append(KeyNumber(f"fe_p_max_MPa[{pos}]", f"FE largest contact pressure, {pos}", _num(c.get("p_max")),
                             "MPa", "lower", "FE"))
        if "ratio_mid_to_hertz" in c:
            out.append(KeyNumber(f"fe_p_over_hertz[{pos}]", f"FE mid-section pressure / Hertz p0, {pos}",
                                 _num(c["ratio_mid_to_hertz"]), "", None, "FE"))
        for member, r in (p.get("root") or {}).items():
            out.append(KeyNumber(f"fe_root_max_principal_MPa[{member}, {pos}]",
                                 f"FE root stress (largest principal, mid face), {member}, {pos}",
                                 _num(r.get("max_principal_mid")), "MPa", "lower", "FE"))
    return out


def loaded_microgeometry_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """loaded_microgeometry: the optimised amounts, the optimiser's status, objective and binding
    constraints, and per case and torque the loaded TE peak-to-peak, peak pressure and edge share
    of the verification after (plain keys) and before (``before.`` keys) the optimisation."""
    de = d["design"]
    out = [KeyNumber(f"theta_um[{k}]", f"optimised amount {k}", _num(v), "um", None, "optimisation")
           for k, v in (de.get("theta_um") or {}).items()]
    out.append(KeyNumber("status", "optimiser status", _num(de.get("status")), "", None, "optimisation"))
    ver, bef = de.get("verified") or {}, de.get("before") or {}
    if "objective_arcsec" in ver:
        out.append(KeyNumber("objective_arcsec", "objective (weighted loaded TE), optimum verified",
                             _num(ver["objective_arcsec"]), "arcsec", "lower", "optimisation"))
    if "objective_arcsec" in bef:
        out.append(KeyNumber("before.objective_arcsec", "objective (weighted loaded TE), start design",
                             _num(bef["objective_arcsec"]), "arcsec", "lower", "optimisation"))
    if de.get("binding") is not None:
        out.append(KeyNumber("binding", "binding constraints at the optimum", "; ".join(de["binding"]) or "none", "",
                             None, "optimisation"))
    names = [c["name"] for c in d["cases"]]
    for prefix, lp, runs in (("", "", d["after"]), ("before.", "before: ", d["before"])):
        for name, run in zip(names, runs):
            out.append(KeyNumber(f"{prefix}te_pp_arcsec[unloaded, {name}]", f"{lp}TE peak-to-peak, unloaded, {name}",
                                 _num(run["unloaded_peak_to_peak_arcsec"]), "arcsec", "lower", "unloaded TE"))
        for q, key, label, unit in (("peak_to_peak_arcsec", "lte_pp_arcsec", "loaded TE peak-to-peak", "arcsec"),
                                    ("p_max_MPa", "p_max_MPa", "peak contact pressure", "MPa"),
                                    ("edge_share_max", "edge_share_max", "largest share of the load at an edge", "")):
            for name, run in zip(names, runs):
                for t in run["torques"]:
                    tl = _torque_label(t["torque_Nm"])
                    out.append(KeyNumber(f"{prefix}{key}[{name}, {tl}]", f"{lp}{label}, {name}, {tl}", _num(t[q]),
                                         unit, "lower", "loaded"))
    return out


#: Statistics of the Monte Carlo / sweep distributions in the summary, per quantity.
_STATS = {"te_p2p_arcsec": ("mean", "sd", "p5", "p50", "p95", "max"), "h1_arcsec": ("p50", "p95")}
_LOADED_STATS = {"te_p2p_arcsec": ("mean", "p5", "p50", "p95", "max"), "p_max_MPa": ("p50", "p95", "max"),
                 "edge_share_max": ("p95", "max")}
_STAT_KEYS = {"te_p2p_arcsec": ("te_pp_arcsec", "TE peak-to-peak", "arcsec"),
              "h1_arcsec": ("te_h1_arcsec", "TE harmonic 1", "arcsec")}
_LOADED_KEYS = {"te_p2p_arcsec": ("lte_pp_arcsec", "loaded TE peak-to-peak", "arcsec"),
                "p_max_MPa": ("p_max_MPa", "peak contact pressure", "MPa"),
                "edge_share_max": ("edge_share_max", "largest share of the load at an edge", "")}


def robust_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """montecarlo and sweep: the nominal drive (unloaded TE, edge contact; with a torque its loaded
    TE and peak pressure), the distributions' statistics of the TE peak-to-peak and first harmonic
    (and of the loaded quantities), the probabilities of edge contact and of a pattern at an edge
    and the share of samples with results. Keys ``mc_*`` (montecarlo) or ``sweep_*`` (sweep)."""
    mc = d["study"] == "montecarlo"
    pre, group, what = ("mc_", "Monte Carlo", "Monte Carlo") if mc else ("sweep_", "sweep", "sweep")
    nom = d.get("nominal") or {}
    out = []
    if "te_p2p_arcsec" in nom:
        out.append(KeyNumber("te_pp_arcsec[nominal]", "TE peak-to-peak, nominal drive", _num(nom["te_p2p_arcsec"]),
                             "arcsec", "lower", "unloaded TE"))
    if "h1_arcsec" in nom:
        out.append(KeyNumber("te_h1_arcsec[nominal]", "TE harmonic 1, nominal drive", _num(nom["h1_arcsec"]),
                             "arcsec", "lower", "unloaded TE"))
    if "edge_contact" in nom:
        out.append(KeyNumber("edge_contact[nominal]", "an edge carries load, nominal drive", _num(nom["edge_contact"]),
                             "", "lower", "unloaded TE"))
    if "loaded_te_p2p_arcsec" in nom:
        tl = _torque_label(nom["torque_Nm"])
        out.append(KeyNumber(f"lte_pp_arcsec[nominal, {tl}]", f"loaded TE peak-to-peak, nominal drive, {tl}",
                             _num(nom["loaded_te_p2p_arcsec"]), "arcsec", "lower", "loaded"))
        out.append(KeyNumber(f"p_max_MPa[nominal, {tl}]", f"peak contact pressure, nominal drive, {tl}",
                             _num(nom["p_max_MPa"]), "MPa", "lower", "loaded"))
    side = (d.get("options") or {}).get("side")
    if isinstance(side, str):
        out.insert(0, KeyNumber("side", "driving flank of the pinion", side, "", None, "geometry"))
    s = d["statistics"]
    out.append(KeyNumber(f"{pre}n_samples", f"{what}: {'samples' if mc else 'design points'}", _num(s["n_samples"]), "",
                         None, group))
    out.append(KeyNumber(f"{pre}feasible_fraction", f"{what}: share of samples with results",
                         _num(s["feasible_fraction"]), "", "higher", group))
    for q, stats in _STATS.items():
        key, label, unit = _STAT_KEYS[q]
        for st in stats:
            if q in s and st in s[q]:
                out.append(KeyNumber(f"{pre}{key}[{st}]", f"{what}: {label}, {st}", _num(s[q][st]), unit, "lower", group))
    share = "probability" if mc else "share of the design points"
    for q, label in (("p_edge_contact", f"{share} with edge contact"),
                     ("p_pattern_at_edge", f"{share} with a contact pattern at an edge")):
        if q in s:
            out.append(KeyNumber(f"{pre}{q}", f"{what}: {label}", _num(s[q]["p"]), "", "lower", group))
    loaded = s.get("loaded") or {}
    for q, stats in _LOADED_STATS.items():
        key, label, unit = _LOADED_KEYS[q]
        for st in stats:
            if q in loaded and st in loaded[q]:
                out.append(KeyNumber(f"{pre}{key}[{st}]", f"{what}: {label}, {st}", _num(loaded[q][st]), unit,
                                     "lower", group))
    return out


_MEMBERS = ("pinion", "gear")


def rating_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """rating: the nominal torque (``nominal.torque_Nm``) and at it the safety factors of the set of
    load factors used (``nominal.used``: the smaller of the two members and each member's), the
    stresses, both methods' K_Hbeta and K_Halpha (``nominal.ltca``, ``nominal.iso``) and which was used;
    with a load spectrum (``spectrum``) the larger damage sum and the smaller safety factor per mode.
    The keys do not carry the torque: the same quantity of two designs rated at different nominal
    torques shares its row of a comparison, beside the row of the torques."""
    out = [KeyNumber("z1", "pinion teeth z1", _num(d["pair"]["z1"]), "", None, "geometry"),
           KeyNumber("z2", "gear teeth z2", _num(d["pair"]["z2"]), "", None, "geometry"),
           KeyNumber("m_n_mm", "normal module m_n", _num(d["pair"]["m_n"]), "mm", None, "geometry")]
    nom = d["nominal"]
    used = nom["used"]
    out.append(KeyNumber("nominal_torque_Nm", "nominal pinion torque of the rating", _num(nom["torque_Nm"]), "N m",
                         None, "rating"))
    for sym, mode in (("S_H", "pitting"), ("S_F", "bending")):
        out.append(KeyNumber(f"{sym}_min", f"{mode} safety {sym} at the nominal torque, the weaker member",
                             _num(min(used[sym])), "", "higher", "rating"))
        for m, member in enumerate(_MEMBERS):
            out.append(KeyNumber(f"{sym}[{member}]", f"{mode} safety {sym} at the nominal torque, {member}",
                                 _num(used[sym][m]), "", "higher", "rating"))
    for sym, label in (("sigma_H", "contact stress sigma_H"), ("sigma_F", "tooth-root stress sigma_F")):
        for m, member in enumerate(_MEMBERS):
            out.append(KeyNumber(f"{sym}_MPa[{member}]", f"{label} at the nominal torque, {member}", _num(used[sym][m]),
                                 "MPa", "lower", "rating"))
    for sym, label in (("K_Hbeta", "face load factor K_Hbeta"), ("K_Halpha", "transverse load factor K_Halpha")):
        for method, name in (("ltca", "gearopt loaded TCA"), ("iso", "ISO 6336-1")):
            out.append(KeyNumber(f"{sym}[{method}]", f"{label} at the nominal torque, {name}", _num(nom[method][sym]),
                                 "", "lower", "rating"))
    out.append(KeyNumber("load_factors_used", "load factors used for the safety factors", _num(d["load_factors_used"]),
                         "", None, "rating"))
    sp = d.get("spectrum")
    if sp:
        for mode, sym in (("pitting", "S_H"), ("bending", "S_F")):
            out.append(KeyNumber(f"D_{mode}_max", f"Miner damage sum, {mode}, the larger member",
                                 _num(max(sp["damage"][mode])), "", "lower", "rating"))
            out.append(KeyNumber(f"{sym}_spectrum_min", f"{mode} safety against the load spectrum, the weaker member",
                                 _num(min(sp["safety"][mode])), "", "higher", "rating"))
    return out


def dynamics_summary(d: dict[str, Any]) -> list[KeyNumber]:
    """dynamics: the pair's geometry, ISO 6336-1's n_E1 (``model``) and per case (``cases[]``) the
    static loaded TE, the largest dynamic factor of both branches and its speed, the model's n_E1
    with the loaded TCA's c_gamma, the lowest speed with contact loss (``null``: none in the sweep),
    the number of jumps, the number of speeds without a converged steady state and the largest
    mesh-order-1 amplitude of the dynamic TE."""
    out = _pair_geometry(d["pair"])
    T = _torque_label(d["options"]["torque_Nm"])
    out.append(KeyNumber("n_E1_iso_rpm", "resonance speed n_E1, ISO 6336-1 (c_gamma of ISO)",
                         _num(d["model"]["n_E1_iso_rpm"]), "rpm", None, "dynamics"))
    for c in d["cases"]:
        n = c["name"]
        out.append(KeyNumber(f"lte_pp_arcsec[{n}, {T}]", f"loaded TE peak-to-peak, {n}",
                             _num(c["static"]["te_loaded_peak_to_peak_arcsec"]), "arcsec", "lower", "loaded"))
        out.append(KeyNumber(f"K_v_max[{n}]", f"largest dynamic factor K_v over the sweep, {n}", _num(c["K_v_max"]), "",
                             "lower", "dynamics"))
        out.append(KeyNumber(f"K_v_max_speed_rpm[{n}]", f"pinion speed of the largest K_v, {n}",
                             _num(c["K_v_max_speed_rpm"]), "rpm", None, "dynamics"))
        out.append(KeyNumber(f"n_E1_ltca_rpm[{n}]", f"resonance speed n_E1 with the loaded TCA's c_gamma, {n}",
                             _num(c["n_E1_ltca_rpm"]), "rpm", None, "dynamics"))
        loss = c["contact_loss_speeds_rpm"]
        out.append(KeyNumber(f"contact_loss_from_rpm[{n}]", f"lowest speed with contact loss, {n}",
                             _num(min(loss)) if loss else None, "rpm", "higher", "dynamics"))
        out.append(KeyNumber(f"jumps[{n}]", f"jumps between coexisting steady states, {n}", len(c["jumps"]), "",
                             "lower", "dynamics"))
        out.append(KeyNumber(f"not_converged[{n}]", f"speeds without a steady state found (either branch), {n}",
                             len(c.get("not_converged_speeds_rpm", [])), "", "lower", "dynamics"))
        o1 = [v[0] for br in ("up", "down") for v in (c[br]["order_te_um"] or []) if v is not None and v[0] is not None]
        out.append(KeyNumber(f"order1_te_um_max[{n}]", f"largest mesh-order-1 amplitude of the dynamic TE, {n}",
                             _num(max(o1)) if o1 else None, "um", "lower", "dynamics"))
    return out


SUMMARIES: dict[str, Callable[[dict[str, Any]], list[KeyNumber]]] = {
    "tca": tca_summary, "geometry": geometry_summary, "planar_tca": planar_tca_summary, "ltca": ltca_summary,
    "crowning": crowning_summary, "fea": fea_summary, "loaded_microgeometry": loaded_microgeometry_summary,
    "montecarlo": robust_summary, "sweep": robust_summary, "rating": rating_summary,
    "dynamics": dynamics_summary,
}
