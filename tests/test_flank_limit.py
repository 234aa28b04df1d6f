"""Folded crowned flanks and undercut teeth: where the real generated flank ends, and that the TE
envelope never drops a real contact.

The oracle (benchmarks/cutting_oracle.py) shares none of the engine's equations: the tooth section is
what the rack-cutter leaves standing (material removal minimised over the generating motion), and
the TE is the rigid, penetration-free position of the two finite sections (bisection on a
point-in-tooth test), tooth pair by tooth pair.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import cutting_oracle as O  # noqa: E402

from gearopt import BasicRack, Gear, GearPair, deg  # noqa: E402
from gearopt.contact.edge import EdgeContact  # noqa: E402
from gearopt.errors import ConvergenceError  # noqa: E402
from gearopt.meshing.tca import TCA, Misalignment  # noqa: E402
from gearopt.units import RAD_TO_ARCSEC  # noqa: E402

A20 = deg(20)


def _gear(z, m, a_c=0.0, x=0.0, beta=0.0, hand="right", a_pl=0.0, undercut=False, name="pinion", b=20.0):
    return Gear(z, m, x=x, b=b, beta=beta, hand=hand, rack=BasicRack.iso53("A", a_c=a_c), a_pl=a_pl,
                allow_undercut=undercut, name=name)


def _oracle_form(g: Gear, r_guess: float):
    """(r_below, r_above, jumped): the oracle's end of the flank (cutting_oracle.flank_end)."""
    return O.flank_end(g, r_guess)


@pytest.mark.parametrize("g, kind", [
    (_gear(22, 2.5, a_c=0.015), "folded"),  # spur, folded by profile crowning
    (_gear(19, 2.0, a_c=0.012, beta=deg(12)), "folded"),  # helical, folded by profile crowning
    (_gear(9, 3.0, undercut=True), "folded"),  # undercut: involute cut by the trochoid
    (_gear(13, 1.5, a_c=0.004, x=0.2, beta=deg(25)), "junction"),  # regular flank down to the fillet
], ids=["spur-crowned", "helical-crowned", "undercut", "regular"])
def test_form_radius_is_where_the_cut_tooth_flank_ends(g, kind):
    r_form = g.r_form
    lo, hi, jumped = _oracle_form(g, r_form)
    # A fold ends the flank at a kink of the cut section (located to the oracle's radius step); at
    # the junction the flank runs tangentially into the fillet and the cutting tool point is
    # ill-conditioned in the oracle (O.JUNCTION_TOL).
    tol = 1e-9 if kind == "folded" else O.JUNCTION_TOL
    assert lo - tol <= r_form <= hi + tol, (r_form, lo, hi)
    assert jumped == (kind == "folded") == g.folded
    # The TCA's on-flank check uses the same end of the flank (mid section).
    pair = GearPair(g, _gear(41, g.m_n, beta=g.beta, hand="left" if g.hand == "right" else "right", name="gear"))
    t = TCA(pair)
    assert lo - tol <= t.form_radius(1) <= hi + tol


def test_largest_unfolded_profile_crowning():
    g = _gear(24, 2.0, a_c=0.01)
    a_max = g.a_c_max_unfolded
    assert 0 < a_max < 0.01
    for f, folds in ((0.95, False), (1.05, True)):
        h = g.with_(rack=replace(g.rack, a_c=f * a_max))
        assert _oracle_form(h, h.r_form)[2] == folds, f
    assert _gear(9, 3.0, undercut=True).a_c_max_unfolded == 0.0


@pytest.mark.parametrize("z1, z2, m, a_c, a_pl, x1, undercut, ridge", [
    (18, 45, 3.0, 0.012, 0.001, 0.0, False, False),
    (22, 70, 1.25, 0.04, 0.002, 0.0, False, False),
    (21, 45, 2.0, 0.045, 0.002, 0.0, False, True),
    (12, 50, 2.0, 0.004, 0.0015, 0.0, True, False),
], ids=["18-45", "22-70", "21-45-ridge", "undercut-12-50"])
@pytest.mark.slow
def test_te_envelope_agrees_with_rigid_contact_oracle(z1, z2, m, a_c, a_pl, x1, undercut, ridge):
    """Spur pinion with profile and longitudinal crowning (aligned: the mid section carries the
    contact): the engine's actual TE equals the rigid contact of the cut sections at every position,
    including where the contact reaches the pinion's flank end, and where the gear rests on the
    ridge left where the tool cut a fold off (edge contact, EdgeContact). The surface TCA alone
    equals it wherever it gives a value and flags (NaN) the ridge positions."""
    pair = GearPair(_gear(z1, m, a_c=a_c, x=x1, a_pl=a_pl, undercut=undercut), _gear(z2, m, name="gear"))
    g1, g2 = pair.pinion, pair.gear
    s1 = O.Section(*O.cut_boundary(z1, m, A20, 1.25, 0.38, x=x1, a_c=a_c), g1.r_a)
    s2 = O.Section(*O.cut_boundary(z2, m, A20, 1.25, 0.38), g2.r_a)
    phi = np.linspace(-math.pi / z1, math.pi / z1, 29)
    env, _, _ = O.rigid_te(s1, s2, z1, z2, pair.a_w, np.r_[0.0, phi])
    oracle = env[1:] - env[0]  # the engine's TE is 0 at phi1 = 0 (pair 0 at the pitch point)
    t = TCA(pair)
    e = EdgeContact(t).sweep(phi)
    assert np.isfinite(e.te_envelope).all() and np.isfinite(oracle).all()
    d = (e.te_envelope - oracle) * RAD_TO_ARCSEC
    assert np.abs(d).max() < 0.1, np.round(d, 3)
    on_ridge = e.active == e.branches.index("pinion_limit") if "pinion_limit" in e.branches else e.active < -1
    assert on_ridge.any() == ridge
    r = t.sweep(phi)
    defined = np.isfinite(r.te_envelope)
    assert np.array_equal(defined, ~on_ridge) and ("ridge_contact" in r.stats) == ridge
    assert np.abs((r.te_envelope - oracle)[defined]).max() * RAD_TO_ARCSEC < 0.1
    # The case exercises the class: the actual TE uses contacts between the true end of the pinion
    # flank and the tool junction (which the junction's form radius used to discard).
    t = TCA(pair)
    lim = t.flank_limit(1)
    r_junction = float(np.hypot(*t.pinion.point("right", "flank", lim.u_junction)[0][:2]))
    k0 = r.pairs.index(0)
    rad = r.radius1[k0][r.driving == k0]
    assert lim.folded and ((rad >= lim.radius) & (rad < r_junction)).any() or ridge


def test_folding_is_reported_in_results():
    pair = GearPair(_gear(21, 2.5, a_c=0.02, a_pl=0.001), _gear(38, 2.5, name="gear"))
    t = TCA(pair)
    r = t.sweep(np.linspace(-0.1, 0.1, 5))
    f = r.stats["folded_flanks"]["pinion"]
    assert f["kind"] == "intersection" and f["r_fold"] < f["r_form"] < f["r_junction"]
    assert 0 < f["a_c_max_unfolded"] < 0.02
    assert "gear" not in r.stats["folded_flanks"]
    assert "folded_flanks" not in TCA(GearPair(_gear(21, 2.5, a_c=0.002, a_pl=0.001),
                                               _gear(38, 2.5, name="gear"))).sweep([0.0]).stats


def test_contact_ratio_of_undercut_pinion_is_the_path_on_real_flanks():
    """eps_alpha of an undercut pinion: the line-contact TCA's own path of contact (where one pair is
    on both active flanks, in pinion angle) over the angular pitch 2 pi/z1."""
    pair = GearPair(_gear(11, 3.0, undercut=True), _gear(47, 3.0, name="gear"))
    t = TCA(pair, contact="line")
    pitch = 2 * math.pi / 11
    phi = np.linspace(-1.2 * pitch, 1.2 * pitch, 4801)
    r = t.sweep(phi, pairs=(0,))
    on = r.on_surface[0]
    span = phi[on].max() - phi[on].min()
    h = phi[1] - phi[0]
    assert abs(span / pitch - pair.eps_alpha) <= 2 * h / pitch, (span / pitch, pair.eps_alpha)
    # the old bound (involute down to the base circle) was larger
    ga = pair.a_w * math.sin(pair.alpha_wt)
    old = (min(math.sqrt(pair.pinion.r_a**2 - pair.pinion.r_b**2), ga) + math.sqrt(pair.gear.r_a**2 - pair.gear.r_b**2)
           - ga) / pair.pinion.p_bt
    assert old - pair.eps_alpha > 0.05


def test_unmodified_pair_off_face_root_is_reported_as_such():
    """Item 5: an unmodified drive with an intersecting angle has no point contact on the teeth;
    the equations converge only far off the face (where the extended flank may be reversed). The
    diagnostic says that, not "false root ... reversed branch"; the edge-contact answer stands."""
    pair = GearPair(_gear(27, 2.0, b=16), _gear(35, 2.0, b=16, name="gear"))
    mis = Misalignment(intersecting=4e-3)
    t = TCA(pair)
    with pytest.raises(ConvergenceError) as ei:
        t.solve_point(0.0, mis=mis)
    msg = str(ei.value)
    assert "no contact point on the face" in msg and "false root" not in msg, msg
    z = float(msg.split("z1 = ")[1].split(" mm")[0])
    assert abs(z) > 8  # the quoted position is off the face (b/2 = 8 mm): check it independently
    w = t.branch.newton(t.guess(), t.prm([0.0], mis=mis)[:, 0])
    assert abs(w[1]) > 8 and abs(w[1] - z) <= 1e-3 * max(1.0, abs(z))
    r = EdgeContact(t).sweep(np.linspace(-0.1, 0.1, 7), mis=mis)
    assert np.isfinite(r.te_envelope).all() and r.edge_contact()
    assert "no contact point on the face" in r.stats["surface"] and "false root" not in r.stats["surface"]


@pytest.mark.parametrize("z, m, x, beta", [(20, 2.0, 0.0, 0.0), (31, 3.5, -0.3, 0.0), (17, 1.25, 0.2, deg(22)),
                                           (60, 8.0, 0.5, deg(35))])
def test_straight_tool_flank_ends_at_the_analytic_limit(z, m, x, beta):
    """Without profile crowning and undercut the numeric flank limit is the tool junction, whose
    radius is the closed form Gear.r_lim (the straight flank's end on the line of action)."""
    from gearopt.geometry.generation import generate_by_rack

    g = _gear(z, m, x=x, beta=beta)
    for side in ("right", "left"):
        lim = generate_by_rack(g).flank_limit(side, 0.0)
        assert lim.kind == "junction" and not lim.folded
        assert lim.radius == pytest.approx(g.r_lim, abs=1e-10)


@pytest.mark.parametrize("z, x, a_c, a_pl", [(12, 0.3, 0.0, 0.0002), (17, 0.3, 0.002, 0.01), (25, -0.2, 0.0, 0.01),
                                             (14, 0.1, 0.004, 0.003), (30, 0.0, 0.0, 0.0005)])
def test_flank_limit_table_shortcut_matches_every_section(z, x, a_c, a_pl):
    """TCA.limit_table computes only the end sections when both end at the tool's junction (a fold
    grows with the plunging shift, monotone in z^2): every section of the face is then regular and
    ends at the same u; otherwise the table holds 9 sections. Checked against each section's own
    GeneratedTooth.flank_limit (independent of the table)."""
    g1 = _gear(z, 3.0, a_c=a_c, x=x, a_pl=a_pl, undercut=True)
    tca = TCA(GearPair(g1, _gear(40, 3.0, name="gear")))
    s, u = tca.limit_table(1)
    zs = np.linspace(0.0, g1.b / 2, 13)
    lims = [tca.pinion.flank_limit("right", float(v), tca.pinion.p0) for v in zs]
    if all(lim.kind == "junction" for lim in lims[::12]):  # both ends regular
        assert s.size == 1
        assert all(lim.kind == "junction" for lim in lims)
        assert max(abs(lim.u - u[0]) for lim in lims) < 1e-12
    else:
        assert s.size == 9
        # the table interpolates each section's limit in z^2
        u_tab = np.interp(zs ** 2, s, u)
        assert np.all(np.isfinite(u_tab))
        for v, lim in zip(zs[::3], lims[::3]):
            assert tca.on_flank(1, np.array([lim.u - 1e-6]), np.array([v]))[0]
            assert not tca.on_flank(1, np.array([lim.u + 1e-3]), np.array([v]))[0]
