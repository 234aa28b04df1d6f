"""The checks of results.json's ``summary`` (docs/results.md, "summary"), independent of
gearopt.summary: the documented keys read from the page's table, and every key number recomputed
from the arrays of results.json (peak-to-peak of the TE envelope, its DFT harmonics, the largest
pressure over the positions, percentiles of samples.csv) or read from the scalar it names. Used by
tests/test_summary.py and, for every scene, tests/test_report_page.py."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest

from gearopt.summary import GROUPS

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "results.md"


# --- the documented keys ---------------------------------------------------------------------------
_PLACE = {"<case>": r"[^\[\]]+", "<torque>": r"\d+(?:\.\d+)? Nm", "<member>": r"pinion|gear",
          "<stat>": r"mean|sd|min|max|p\d+", "<position>": r"phi1 -?\d+(?:\.\d+)? deg", "<input>": r"[\w.]+",
          "<amount>": r"C_alpha|f_H_alpha|C_beta|f_H_beta",
          "<chart>": r"F_alpha|f_f_alpha|f_H_alpha|C_alpha|F_beta|f_f_beta|f_H_beta|C_beta", "<side>": r"right|left",
          "<method>": r"ltca|iso"}


def documented_summary_keys(doc: Path = DOC) -> list[str]:
    """Regular expressions of the keys of the table in docs/results.md's section ``## summary``."""
    text = doc.read_text(encoding="utf-8")
    section = text.split("\n## summary\n", 1)[1].split("\n## ", 1)[0]
    pats = []
    for line in section.splitlines():
        if not line.startswith("| `"):
            continue
        for tok in re.findall(r"`([^`]+)`", line.split("|")[1]):
            pat = re.escape(tok)
            for ph, rx in _PLACE.items():
                pat = pat.replace(re.escape(ph), f"(?:{rx})")
            pats.append(pat)
    return pats


def undocumented_keys(keys: list[str], doc: Path = DOC) -> list[str]:
    pats = documented_summary_keys(doc)
    base = [p for p in pats if not p.startswith(("before", "sweep_"))]

    def ok(k: str) -> bool:
        if k.startswith("before."):
            return ok(k[len("before."):])
        if k.startswith("sweep_"):
            k = "mc_" + k[len("sweep_"):]
        return any(re.fullmatch(p, k) for p in base)

    return [k for k in keys if not ok(k)]


def te_pp(case: dict) -> float:
    env = np.array([np.nan if v is None else v for v in case["te_envelope_arcsec"]], float)
    return float(np.nanmax(env) - np.nanmin(env))


def harmonic(case: dict, k: int, z1: int) -> float:
    """Amplitude of mesh order k of the TE envelope (a DFT over the whole cycles the samples span)."""
    env = np.array(case["te_envelope_arcsec"], float)
    phi = np.array(case["phi1"], float)
    cycles = round((phi[1] - phi[0]) * len(phi) * z1 / (2 * math.pi))
    spec = np.fft.fft(env) / len(env)
    return float(2 * abs(spec[k * cycles]))


def _check_tca_cases(s: dict, cases: list, z1: int | None, prefix: str = "") -> None:
    for c in cases:
        lab = c["label"]
        assert s[f"{prefix}te_pp_arcsec[{lab}]"] == pytest.approx(te_pp(c), abs=1e-9)
        if c.get("harmonics_arcsec") is not None and z1 is not None:
            assert s[f"{prefix}te_h1_arcsec[{lab}]"] == pytest.approx(harmonic(c, 1, z1), abs=1e-9)
        if c.get("edge_analysis"):
            assert s[f"{prefix}edge_contact[{lab}]"] is c["edge_carries_load"]


def _check_ltca_torques(s: dict, run: dict, suffix: str = "", prefix: str = "") -> None:
    for t in run["torques"]:
        lab = f"{t['torque_Nm']:g} Nm"
        te = np.array(t["te_loaded_arcsec"], float)
        assert s[f"{prefix}lte_pp_arcsec[{suffix}{lab}]"] == pytest.approx(te.max() - te.min(), abs=1e-9)
        assert s[f"{prefix}p_max_MPa[{suffix}{lab}]"] == pytest.approx(max(t["p_max_per_position_MPa"]), abs=1e-9)
        assert s[f"{prefix}edge_share_max[{suffix}{lab}]"] == pytest.approx(max(t["edge_share"]), abs=1e-12)


def _samples(out: Path) -> dict[str, np.ndarray]:
    with open(out / "samples.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) if r[k] != "" else np.nan for r in rows]) for k in rows[0]}


def check_summary(res: dict, out: Path) -> None:
    """The checks of a scene run's ``summary`` (results.json ``res`` in directory ``out``): its place
    and form, every key documented, and every value equal to the number recomputed here from the
    arrays of results.json (or samples.csv) or read from the scalar it names."""
    assert list(res)[:3] == ["study", "scene", "summary"], "summary right after study and scene"
    entries = res["summary"]
    assert entries, "every study has key numbers"
    for e in entries:
        assert set(e) == {"key", "label", "value", "unit", "better", "group"}
        assert e["group"] in GROUPS and e["better"] in (None, "lower", "higher")
    keys = [e["key"] for e in entries]
    assert len(set(keys)) == len(keys)
    assert undocumented_keys(keys) == [], "summary keys missing in docs/results.md's summary table"
    s = {e["key"]: e["value"] for e in entries}
    st = res["study"]
    # every study names its pair: its own pair block, else meta.pair (the scene's pair)
    pair = res["pair"] if {"z1", "a"} <= set(res.get("pair", {})) else res["meta"]["pair"]
    assert (s["z1"], s["z2"], s["m_n_mm"], s["a_mm"]) == (pair["z1"], pair["z2"], pair["m_n"], pair["a"])
    assert (s["z1"], s["z2"]) == (res["meta"]["pair"]["z1"], res["meta"]["pair"]["z2"])
    if "eps_alpha" in res.get("pair", {}):
        assert s["eps_alpha"] == res["pair"]["eps_alpha"]
    side = res.get("pair", {}).get("side") or res.get("options", {}).get("side") or res["meta"]["pair"].get("side")
    assert s.get("side") == side
    if st == "tca":
        _check_tca_cases(s, res["cases"], res["pair"]["z1"])
        for member, sides in res.get("inspection", {}).items():
            for side, v in sides.items():
                assert s[f"chart_F_alpha_um[{member} {side}]"] == v["charts_um"]["F_alpha"]
                assert s[f"chart_f_H_beta_um[{member} {side}]"] == v["charts_um"]["f_H_beta"]
    elif st == "geometry":
        m = res["members"]
        assert (s["z1"], s["z2"]) == (m["pinion"]["z"], m["gear"]["z"])
        assert s["eps_gamma"] == pytest.approx(s["eps_alpha"] + s["eps_beta"])
        for member in ("pinion", "gear"):
            assert s[f"form_margin_mm[{member}]"] == pytest.approx(m[member]["r_active_start"] - m[member]["r_form"])
    elif st == "planar_tca":
        te = np.array(res["positions"]["te_arcsec"], float)
        assert s["te_max_abs_arcsec"] == pytest.approx(np.abs(te).max(), abs=1e-12)
    elif st == "ltca":
        u = np.array(res["te_unloaded_arcsec"], float)
        assert s["te_pp_arcsec[unloaded]"] == pytest.approx(u.max() - u.min(), abs=1e-9)
        _check_ltca_torques(s, res)
        assert f"K_Hbeta[{res['nominal_torque_Nm']:g} Nm]" in s
    elif st in ("montecarlo", "sweep"):
        pre = "mc_" if st == "montecarlo" else "sweep_"
        smp = _samples(out)
        te = smp["te_p2p_arcsec"][np.isfinite(smp["te_p2p_arcsec"])]
        assert s[f"{pre}n_samples"] == len(smp["sample"])
        assert s[f"{pre}te_pp_arcsec[p95]"] == pytest.approx(np.percentile(te, 95), rel=1e-12)
        assert s[f"{pre}te_pp_arcsec[p50]"] == pytest.approx(np.median(te), rel=1e-12)
        assert s[f"{pre}te_pp_arcsec[max]"] == pytest.approx(te.max(), rel=1e-12)
        edge = smp["edge_contact"][np.isfinite(smp["te_p2p_arcsec"])]
        assert s[f"{pre}p_edge_contact"] == pytest.approx(edge.mean(), abs=1e-12)
        if "loaded_te_p2p_arcsec" in smp:
            lte = smp["loaded_te_p2p_arcsec"][np.isfinite(smp["loaded_te_p2p_arcsec"])]
            assert s[f"{pre}lte_pp_arcsec[p95]"] == pytest.approx(np.percentile(lte, 95), rel=1e-12)
        else:
            assert not any(k.startswith(f"{pre}lte") or k.startswith("lte") for k in s)
    elif st == "crowning":
        _check_tca_cases(s, res["after"], None)
        _check_tca_cases(s, res["before"], None, prefix="before.")
        assert s["pinion_a_pl_per_mm"] == res["design"]["settings"]["a_pl"]
        assert s["C_beta_um[pinion]"] == res["design"]["iso_um"]["C_beta"]
    elif st == "loaded_microgeometry":
        for i, c in enumerate(res["cases"]):
            _check_ltca_torques(s, res["after"][i], suffix=f"{c['name']}, ")
            _check_ltca_torques(s, res["before"][i], suffix=f"{c['name']}, ", prefix="before.")
        for k, v in res["design"]["theta_um"].items():
            assert s[f"theta_um[{k}]"] == v
    elif st == "fea":
        for p in res["positions"]:
            pos = f"phi1 {math.degrees(p['phi1']):.4g} deg"
            assert s[f"fe_loaded_te_arcsec[{pos}]"] == p["loaded_te_arcsec"]
            assert s[f"fe_p_max_MPa[{pos}]"] == p["contact"]["p_max"]
            for member in ("pinion", "gear"):
                assert s[f"fe_root_max_principal_MPa[{member}, {pos}]"] == p["root"][member]["max_principal_mid"]
    elif st == "rating":
        nom = res["nominal"]
        assert s["nominal_torque_Nm"] == nom["torque_Nm"]
        for sym in ("S_H", "S_F"):
            assert s[f"{sym}_min"] == min(nom["used"][sym])
            assert [s[f"{sym}[{m}]"] for m in ("pinion", "gear")] == nom["used"][sym]
            assert [s[f"{sym.replace('S_', 'sigma_')}_MPa[{m}]"] for m in ("pinion", "gear")] == \
                nom["used"][sym.replace("S_", "sigma_")]
        assert s["K_Hbeta[ltca]"] == nom["ltca"]["K_Hbeta"] and s["K_Hbeta[iso]"] == nom["iso"]["K_Hbeta"]
        assert s["K_Halpha[ltca]"] == nom["ltca"]["K_Halpha"] and s["K_Halpha[iso]"] == nom["iso"]["K_Halpha"]
        assert not any(k.endswith(" Nm]") for k in s), "a rating key carries the torque"
        assert s["load_factors_used"] == res["load_factors_used"]
        if "spectrum" in res:
            assert s["D_pitting_max"] == max(res["spectrum"]["damage"]["pitting"])
            assert s["S_F_spectrum_min"] == min(res["spectrum"]["safety"]["bending"])
        else:
            assert "D_pitting_max" not in s
    elif st == "dynamics":
        T = f"{res['options']['torque_Nm']:g} Nm"
        for c in res["cases"]:
            n = c["name"]
            assert s[f"K_v_max[{n}]"] == max(k for b in ("up", "down") for k in c[b]["K_v"] if k is not None)
            assert s[f"lte_pp_arcsec[{n}, {T}]"] == pytest.approx(np.ptp(c["static"]["te_loaded_arcsec"]), rel=1e-9)
            loss = [v for b in ("up", "down") for v, lost in zip(c["speeds_rpm"], c[b]["contact_loss"]) if lost]
            assert s[f"contact_loss_from_rpm[{n}]"] == (min(loss) if loss else None)
            assert s[f"jumps[{n}]"] == len(c["jumps"])
    else:  # pragma: no cover - a new study: add its checks here
        pytest.fail(f"no summary checks for study {st!r}")
