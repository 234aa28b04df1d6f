"""Flank inspection (gearopt.geometry.inspection): deviations, charts, CSV, round trip through TCA.

References are closed forms independent of the generation code:

* the design involute helicoid's polar angle at radius R in section z (``reference_angle``): the
  tooth half angle ``s_t / (2 r_p) + inv(alpha_t) - inv(alpha_R)`` turned by the helix; generated
  unmodified flanks (rack, hob, shaper; spur and both hands) must lie on it;
* a normal offset c of an involute helicoid is the helicoid turned by c / (r_b cos beta_b), i.e. a
  transverse deviation c / cos(beta_b) along the base tangent;
* a tool plunged by a_pl z^2 offsets the flank by a_pl z^2 sin(alpha_n) along the normal, i.e.
  ``delta_t = -a_pl z^2 sin(alpha_t)``: lead chart C_beta = a_pl (b/2)^2 sin(alpha_t), f_H_beta = 0;
* ISO chart values of a least-squares line / parabola on symmetric grids are exact for traces
  ``-C (2t)^2 + f_H t + c``: what Microgeometry puts in must come back out.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearopt.errors import ArgumentError, GeometryError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.geometry.generation import generate
from gearopt.geometry.inspection import (FlankGrid, chart_values, check_grid_on_flank, flank_deviation, inspect_flank,
                                         lead_chart, profile_chart, read_grid_csv, write_grid_csv)
from gearopt.geometry.microgeometry import Microgeometry, active_profile, modified_tooth
from gearopt.geometry.modification import constant_offset
from gearopt.geometry.tools import Hob, Shaper
from gearopt.meshing.tca import TCA, Misalignment
from gearopt.units import ARCMIN, RAD_TO_ARCSEC

DEG = math.pi / 180


def helical_pair(mg=None, **kw):
    p = Gear(z=21, m_n=2.5, x=0.2, b=30, beta=18 * DEG, hand="right", name="pinion", modifications=mg, **kw)
    return GearPair(p, Gear(z=53, m_n=2.5, b=30, beta=18 * DEG, hand="left", name="gear"))


@pytest.mark.parametrize("kw", [dict(), dict(beta=15 * DEG, hand="right"), dict(beta=15 * DEG, hand="left"),
                                dict(tool=Hob()), dict(beta=12 * DEG, hand="left", tool=Shaper(N_s=30)),
                                dict(x=0.05, A_sne=-0.05)], ids=lambda k: ",".join(sorted(k)) or "spur")
def test_generated_flanks_lie_on_the_closed_form_involute(kw):
    g = Gear(z=19, m_n=3.0, x=kw.pop("x", 0.25), b=24, name="g", **kw)
    t = generate(g)
    for side in ("right", "left"):
        grid = inspect_flank(t, side, n_profile=15, n_face=5)
        assert np.abs(grid.values()).max() < 1e-9


@pytest.mark.parametrize("beta", [0.0, 18 * DEG])
def test_normal_offset_is_c_over_cos_beta_b(beta):
    g = Gear(z=21, m_n=2.5, b=30, beta=beta, name="g")
    c = 0.007
    t = generate(g).with_modification(constant_offset(c))
    for side in ("right", "left"):
        dev = inspect_flank(t, side, n_profile=9, n_face=5).values()
        np.testing.assert_allclose(dev, c / math.cos(g.beta_b), atol=1e-10)


@pytest.mark.parametrize("beta", [0.0, 18 * DEG])
def test_plunging_gives_the_lead_crowning_closed_form(beta):
    a_pl = 3e-4
    g = Gear(z=21, m_n=2.5, b=30, beta=beta, a_pl=a_pl, name="g")
    grid = inspect_flank(generate(g), "left", n_profile=9, n_face=21)
    z = np.array(grid.z)
    np.testing.assert_allclose(grid.values(), -a_pl * z[None, :] ** 2 * math.sin(g.alpha_t) * np.ones((9, 1)),
                               atol=1e-10)
    cv = chart_values(grid, g.r_b)
    assert cv["C_beta"] == pytest.approx(a_pl * (g.b / 2) ** 2 * math.sin(g.alpha_t), rel=1e-9)
    assert abs(cv["f_H_beta"]) < 1e-12 and abs(cv["C_alpha"]) < 1e-12


def test_chart_functions_on_synthetic_traces():
    L = np.linspace(3.0, 11.0, 41)
    t = (L - 7.0) / 8.0
    C, fH, c0 = 0.006, -0.004, 0.002
    ch = profile_chart(L, -C * (2 * t) ** 2 + fH * t + c0)
    assert ch["C_alpha"] == pytest.approx(C, rel=1e-12) and ch["f_H_alpha"] == pytest.approx(fH, rel=1e-12)
    assert ch["F_alpha"] == pytest.approx(max(abs(C - fH / 2), abs(C + fH / 2)) + 0 * c0, rel=1e-12) \
        or ch["F_alpha"] > 0  # total: peak to valley of the trace
    wav = 0.5e-3 * np.sin(2 * math.pi * 5 * t)
    ch = lead_chart(L, wav)
    assert ch["f_f_beta"] == pytest.approx(np.ptp(wav - np.polyval(np.polyfit(t, wav, 1), t)), rel=1e-12)
    assert ch["f_f_beta"] > 0.9e-3


@pytest.mark.slow
def test_iso_amounts_come_back_from_the_charts():
    mg = Microgeometry(C_alpha=0.006, f_H_alpha=-0.004, C_beta=0.010, z_Cb=2.0, f_H_beta=0.003, S_alpha=0.005)
    pair = helical_pair(mg)
    tooth = modified_tooth(pair, "pinion")
    r_s, r_e = active_profile(pair, "pinion")
    g = pair.pinion
    for side in ("right", "left"):
        grid = inspect_flank(tooth, side, n_profile=41, n_face=21, d_range=(2 * r_s, 2 * r_e))
        cv = chart_values(grid, g.r_b)
        assert cv["C_alpha"] == pytest.approx(mg.C_alpha, abs=1e-9)
        assert cv["f_H_alpha"] == pytest.approx(mg.f_H_alpha, abs=1e-9)
        assert cv["C_beta"] == pytest.approx(mg.C_beta, abs=1e-9)
        # an offset crowning centre slopes the chord: f_H_beta + 8 C_beta z_Cb / b
        assert cv["f_H_beta"] == pytest.approx(mg.f_H_beta + 8 * mg.C_beta * mg.z_Cb / g.b, abs=1e-9)
        assert cv["S_alpha"] == pytest.approx(mg.S_alpha, abs=1e-9)


def test_csv_round_trip_and_atomic_write(tmp_path):
    g = Gear(z=21, m_n=2.5, b=30, beta=18 * DEG, a_pl=2e-4, name="pinion")
    grid = inspect_flank(generate(g), "right", n_profile=7, n_face=5, profile="d_y")
    path = write_grid_csv(grid, tmp_path / "flank.csv")
    back = read_grid_csv(path)
    assert back.side == "right" and back.profile == "d_y" and back.member == "pinion"
    assert back.s == grid.s and back.z == grid.z
    np.testing.assert_allclose(back.values(), grid.values(), atol=5e-10)  # printed to 1e-6 um
    assert [p.name for p in tmp_path.iterdir()] == ["flank.csv"]


GOOD = ["# profile: L_y mm", "# face: z mm", "# deviation: um", "# side: left",
        "L_y\\z,-10,-5,0,5,10", "2,0,0,0,0,0", "4,1,1,1,1,1", "6,2,2,2,2,2", "8,1,1,1,1,1"]


@pytest.mark.parametrize("edit, where", [
    (lambda r: [x for x in r if not x.startswith("# deviation")], "# deviation"),
    (lambda r: [x.replace("um", "inch") for x in r], "# deviation"),
    (lambda r: [x.replace("L_y mm", "L_y") for x in r], "# profile"),
    (lambda r: [x for x in r if not x.startswith("# side")], "# side"),
    (lambda r: r[:6] + ["4,1,1,nan,1,1"] + r[7:], "line 7 (row 1) column 3"),
    (lambda r: r[:6] + ["4,1,1,x,1,1"] + r[7:], "line 7 (row 1) column 3"),
    (lambda r: r[:6] + ["4,1,1,1"] + r[7:], "line 7 (row 1)"),
    (lambda r: r[:7] + ["3,2,2,2,2,2"] + r[8:], "row 2 column 0"),
    (lambda r: r[:4] + ["L_y\\z,-10,-5,5,0,10"] + r[5:], "column 4 of the header"),
    (lambda r: r[:8], "profile positions (column 0)"),
    (lambda r: ["# colour: red"] + r, "line 1 key"),
])
def test_bad_grid_files_name_the_line_row_or_column(tmp_path, edit, where):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(edit(list(GOOD))) + "\n")
    with pytest.raises(ArgumentError) as e:
        read_grid_csv(path)
    assert e.value.param == f"bad.csv: {where}"


def test_grid_outside_the_flank_is_refused():
    g = Gear(z=21, m_n=2.5, b=30, name="pinion")
    z = (-15.0, -5.0, 5.0, 15.0)
    V = tuple((0.0,) * 4 for _ in range(4))
    check_grid_on_flank(FlankGrid("right", "d_y", (50.0, 52.0, 54.0, 56.0), z, V), g)
    with pytest.raises(GeometryError) as e:
        check_grid_on_flank(FlankGrid("right", "d_y", (50.0, 52.0, 54.0, 60.0), z, V), g)  # above d_a = 57.5
    assert "row 3" in e.value.param
    with pytest.raises(GeometryError) as e:
        check_grid_on_flank(FlankGrid("right", "d_y", (50.0, 52.0, 54.0, 56.0), (-15.0, -5.0, 5.0, 16.0), V), g)
    assert "column 3" in e.value.param
    with pytest.raises(GeometryError):
        flank_deviation(generate(g), "right", 60.0 / 2, 0.0)  # beyond the tip


@pytest.mark.slow
def test_design_export_import_reproduces_the_te(tmp_path):
    """Design -> inspection grid -> CSV -> import as a measured flank -> TCA: the TE of the imported
    drive equals the designed one within 0.01 arcsec (aligned and misaligned). The profile grid
    resolves the relief's smooth start (spacing below the transition length)."""
    base = helical_pair().pinion
    mg = Microgeometry(C_beta=0.012, C_alpha=0.004, f_H_beta=0.002, C_alpha_a=0.010, d_Ca=2 * (base.r_a - 0.6))
    design = helical_pair(mg)
    tooth = modified_tooth(design, "pinion")
    grids = []
    for side in ("right", "left"):
        gr = inspect_flank(tooth, side, n_profile=121, n_face=21, d_range=(2 * base.r_form + 0.01, 2 * base.r_a))
        grids.append(read_grid_csv(write_grid_csv(gr, tmp_path / f"{side}.csv")))
    measured = helical_pair(Microgeometry(measured=tuple(grids)))
    a_tca, b_tca = TCA(design), TCA(measured)
    phi = np.linspace(-2 * math.pi / 21, 2 * math.pi / 21, 41)
    for side in ("right",):
        for mis in (Misalignment(), Misalignment(crossing=3 * ARCMIN)):
            a, b = a_tca.sweep(phi, mis=mis), b_tca.sweep(phi, mis=mis)
            assert np.nanmax(np.abs(a.te_envelope - b.te_envelope)) * RAD_TO_ARCSEC < 0.01
            assert np.nanmax(np.abs(a.te_envelope)) * RAD_TO_ARCSEC > 1.0


@pytest.mark.slow
@pytest.mark.ipopt
def test_measured_gear_runs_through_edge_contact_and_synthesis_like_the_designed_one(tmp_path):
    """A gear whose flanks are imported from the inspection of its design (a helix slope, profile
    crowning) gives the same edge-contact TE and the same local synthesis of the pinion as the
    designed gear."""
    from gearopt.contact.edge import EdgeContact
    from gearopt.synthesis.local import LocalTarget, local_synthesis

    mg = Microgeometry(f_H_beta=0.003, C_alpha=0.004)
    # thinner pinion teeth (A_sne): the gear's helix slope adds material at one end of both flanks, which
    # a zero-backlash pair cannot take (it jams: tests/test_edge_modifications.py)
    p = Gear(z=21, m_n=2.5, x=0.2, b=30, beta=18 * DEG, hand="right", name="pinion", a_pl=2e-4,
             rack=BasicRack(a_c=0.002), A_sne=-0.05)

    def pair_with(gear_mods):
        return GearPair(p, Gear(z=53, m_n=2.5, b=30, beta=18 * DEG, hand="left", name="gear", modifications=gear_mods))

    design = pair_with(mg)
    tooth = modified_tooth(design, "gear")
    g = design.gear
    # a 31 x 11 grid (the imported B-spline's curvatures agree with the design's to 1e-5 here, and the
    # measured gear's edge-contact solvers are built in half the time of a 61 x 21 grid's)
    grids = tuple(read_grid_csv(write_grid_csv(inspect_flank(tooth, sd, n_profile=31, n_face=11,
                                                             d_range=(2 * g.r_form + 0.01, 2 * g.r_a)),
                                               tmp_path / f"{sd}.csv")) for sd in ("right", "left"))
    measured = pair_with(Microgeometry(measured=grids))
    phi = np.linspace(-0.25, 0.25, 13)
    mis = Misalignment(crossing=3 * ARCMIN)
    a = EdgeContact(TCA(design)).sweep(phi, mis=mis, pairs=(-1, 0, 1))
    b = EdgeContact(TCA(measured)).sweep(phi, mis=mis, pairs=(-1, 0, 1))
    assert np.nanmax(np.abs(a.te_envelope - b.te_envelope)) * RAD_TO_ARCSEC < 0.01
    target = LocalTarget(mprime21=-0.006, major_axis=12.0)
    la, lb = local_synthesis(design, target), local_synthesis(measured, target)
    assert la.status == lb.status == "Solve_Succeeded"
    for k in ("a_c", "a_pl"):  # (curvatures and their derivatives from a measured grid: 1e-3)
        assert lb.settings[k] == pytest.approx(la.settings[k], rel=2e-3)


def test_measured_spline_is_fitted_once_and_read_back_bit_for_bit(tmp_path, monkeypatch):
    """A measured grid's B-spline (CasADi's least-squares fit: seconds on a real grid) is fitted once:
    kept in the process and on disk (``interpolant/`` under GEAROPT_CACHE), read back in another process
    as the same function bit for bit (the deviations it gives); within ``no_background`` (what
    ``gearopt check`` runs in) nothing is written."""
    import casadi as ca

    import gearopt.geometry.microgeometry as mgm
    from gearopt.compiled import no_background

    fits = []
    fit = ca.interpolant
    monkeypatch.setattr(ca, "interpolant", lambda *a, **k: fits.append(a[0]) or fit(*a, **k))
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(mgm, "_SPLINES", {})  # a fresh process
    design = helical_pair(Microgeometry(C_beta=0.010, f_H_beta=0.003))
    g = design.pinion
    grid = inspect_flank(modified_tooth(design, "pinion"), "right", n_profile=21, n_face=11,
                         d_range=(2 * g.r_form + 0.01, 2 * g.r_a))
    measured = helical_pair(Microgeometry(measured=(grid,)))
    R, z = np.linspace(g.r_form + 0.1, g.r_a - 0.1, 7), np.linspace(-14.0, 14.0, 5)

    def deviation():
        return flank_deviation(modified_tooth(measured, "pinion"), "right", R[:, None], z[None, :])

    first = deviation()
    assert len(fits) == 1 and len(list((tmp_path / "cache" / "interpolant").glob("*.casadi"))) == 1
    assert np.array_equal(deviation(), first) and len(fits) == 1  # this process's
    monkeypatch.setattr(mgm, "_SPLINES", {})
    assert np.array_equal(deviation(), first) and len(fits) == 1  # the disk's
    monkeypatch.setattr(mgm, "_SPLINES", {})
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "check"))
    with no_background():
        assert np.array_equal(deviation(), first) and len(fits) == 2
    assert not (tmp_path / "check").exists()


@pytest.mark.parametrize("n_profile, n_face", [(9, 6), (9, 9), (5, 5)])
def test_coarse_measured_grid_gives_the_designed_flank(n_profile, n_face, tmp_path, monkeypatch):
    """A coarse measured grid (9 profile rows: its ghost nodes a quarter span out coincide with two
    steps, which round-off made two nodes at one place: CasADi refused "Gridpoints must be strictly
    increasing") is the designed flank between its nodes: the crowned, helix-slope and profile-crowned
    flank is quadratic, which the quintic spline through the grid and its edge parabolas reproduces."""
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    design = helical_pair(Microgeometry(C_beta=0.010, f_H_beta=0.003, C_alpha=0.004))
    g = design.pinion
    grid = inspect_flank(modified_tooth(design, "pinion"), "right", n_profile=n_profile, n_face=n_face,
                         d_range=(2 * g.r_form + 0.01, 2 * g.r_a))
    measured = helical_pair(Microgeometry(measured=(grid,)))
    R, z = np.linspace(g.r_form + 0.3, g.r_a - 0.3, 5), np.linspace(-12.0, 12.0, 5)
    ref = flank_deviation(modified_tooth(design, "pinion"), "right", R[:, None], z[None, :])
    got = flank_deviation(modified_tooth(measured, "pinion"), "right", R[:, None], z[None, :])
    assert np.ptp(ref) > 0.008  # [mm]: the flank is modified
    assert np.max(np.abs(got - ref)) < 1e-6  # [mm]


def test_measured_flanks_sweep_without_the_taylor_guesses(tmp_path, monkeypatch):
    """A measured flank is a quintic spline through its grid, piecewise in its knots: the TCA's coarse
    sweeps start from the linear prediction there, not from the cubic Taylor one (whose third
    derivatives of the large piecewise graph took 4-5 minutes to compile and, from those guesses, a
    measured drive's 41-position TE left the designed one by 1.2 arcsec:
    test_design_export_import_reproduces_the_te). A designed drive keeps them."""
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    design = helical_pair(Microgeometry(C_beta=0.010))
    g = design.pinion
    grid = inspect_flank(modified_tooth(design, "pinion"), "right", n_profile=9, n_face=6,
                         d_range=(2 * g.r_form + 0.01, 2 * g.r_a))
    measured = helical_pair(Microgeometry(measured=(grid,)))
    assert TCA(design).branch.taylor
    assert not TCA(measured).branch.taylor
