"""The top-level ``summary`` of results.json (gearopt.summary, docs/results.md "summary").

Every key number must repeat a number of the same results.json: the tests below recompute each
from the arrays (peak-to-peak of the TE envelope, its DFT harmonics, the largest pressure over the
positions, percentiles of samples.csv) or read the scalar it names, independently of
gearopt.summary (tests/summary_check.py); every key must match a row of docs/results.md's summary
table; quantities a study does not have are absent (never 0). Every scene's summary is checked with
its page in tests/test_report_page.py (one run per scene)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gearopt.summary import GROUPS, KeyNumber, format_value, summarize, summary_dicts, summary_from_results

from summary_check import harmonic, te_pp, undocumented_keys

ROOT = Path(__file__).resolve().parents[1]


def test_documented_keys_parser_refuses_an_undocumented_key():
    assert undocumented_keys(["te_pp_arcsec[aligned]", "before.p_max_MPa[aligned, 100 Nm]", "sweep_te_pp_arcsec[p95]",
                              "fe_root_max_principal_MPa[gear, phi1 -6 deg]"]) == []
    assert undocumented_keys(["te_pp_um[aligned]", "p_max_MPa[200 N]", "mc_te_pp_arcsec[p97.5x]"]) == [
        "te_pp_um[aligned]", "p_max_MPa[200 N]", "mc_te_pp_arcsec[p97.5x]"]


# --- KeyNumber --------------------------------------------------------------------------------------
def test_key_number_checks_and_round_trip():
    k = KeyNumber("te_pp_arcsec[aligned]", "TE peak-to-peak, aligned", 18.35, "arcsec", "lower", "unloaded TE")
    assert KeyNumber.from_dict(k.to_dict()) == k
    assert set(k.to_dict()) == {"key", "label", "value", "unit", "better", "group"}
    with pytest.raises(ValueError, match="better"):
        KeyNumber("x", "x", 1.0, better="smaller")
    with pytest.raises(ValueError, match="group"):
        KeyNumber("x", "x", 1.0, group="misc")
    with pytest.raises(ValueError, match="not finite"):
        KeyNumber("x", "x", math.nan)
    with pytest.raises(ValueError, match="duplicate"):
        summary_dicts([k, k])
    assert "unloaded TE" in GROUPS


def test_format_value():
    assert format_value(None) == "\u2014"
    assert format_value(True) == "yes" and format_value(False) == "no"
    assert format_value(20) == "20"
    assert format_value(18.353872782287834) == "18.35"
    assert format_value(-2.66e-15) == "0"  # round-off of a zero backlash
    assert format_value(7.563e-06) == "7.563e-6"
    assert format_value(1453.2) == "1453"
    assert format_value("Solve_Succeeded") == "Solve_Succeeded"


def test_summary_from_results_prefers_the_stored_summary():
    stored = [KeyNumber("eps_alpha", "eps", 1.5, "", "higher").to_dict()]
    assert summary_from_results({"study": "tca", "summary": stored}) == [KeyNumber.from_dict(stored[0])]
    assert summarize({"study": "no_such_study"}) == []


# --- a real TCA result, in process (fast) ------------------------------------------------------------
@pytest.fixture(scope="module")
def tca_result():
    from gearopt.io.scene import load_scene

    return load_scene(ROOT / "problems" / "tca_spur_crowned.toml").build().run()


def test_tca_summary_repeats_the_arrays(tca_result):
    d = tca_result.to_dict()
    s = {k.key: k for k in tca_result.summary()}
    assert s["z1"].value == d["pair"]["z1"] == 20 and s["z2"].value == 40
    assert s["m_n_mm"].value == 3.0 and s["m_n_mm"].unit == "mm"
    assert s["eps_alpha"].value == d["pair"]["eps_alpha"] and s["eps_alpha"].better == "higher"
    for case in d["cases"]:
        lab = case["label"]
        assert s[f"te_pp_arcsec[{lab}]"].value == pytest.approx(te_pp(case), abs=1e-9)
        assert s[f"te_pp_arcsec[{lab}]"].better == "lower"
        for k in (1, 2, 3):
            assert s[f"te_h{k}_arcsec[{lab}]"].value == pytest.approx(harmonic(case, k, 20), abs=1e-9)
        assert f"edge_contact[{lab}]" not in s  # no edge analysis: absent, not False
    assert set(s) >= {"te_pp_arcsec[aligned]", "te_pp_arcsec[misaligned]"}
    # quantities of other studies are absent, never 0
    assert not any(k.startswith(("lte_pp", "p_max", "mc_", "fe_")) for k in s)
    assert undocumented_keys(list(s)) == []
