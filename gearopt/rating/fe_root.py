"""Tooth-root stress from the FE model (CalculiX) beside ISO 6336-3's nominal root stress sigma_F0.

ISO 6336-3:2019 method B places the whole tangential load on one tooth pair at the outer point of
single pair contact of the member rated (diameter d_en, clause 6.2) and evaluates the bending stress
at the critical section, the chord between the points where the fillet's tangent makes 30 deg with
the tooth centre line: sigma_F0 = F_t / (b m_n) Y_F Y_S Y_beta Y_B Y_DT (clause 5, eq. (3)).
:func:`fe_root_stress` runs :class:`gearopt.fea.model.GearFEModel` of the same pair at the pinion
angle where that member's contact lies at d_en / 2, with the nominal torque, and reads the largest
principal stress in the tension fillet at mid face (docs/rating.md, "Root stress from FE").

Only the rated tooth pair has a contact definition (:func:`single_pair_deck`): ISO's load case is the
whole load on one pair, and a neighbouring pair, just out of contact in the unloaded mesh (its tip
corner at the end of its path of contact), closes under the load's deflection on finer meshes and
takes up to a fifth of the load (docs/rating.md, "Root stress from FE"). The three teeth of each member
are still modelled, for the stiffness of the rim around the rated tooth.

The FE model is of the pair without micro-geometry and aligned (:func:`gearopt.rating.pair.reference_pair`):
sigma_F0 describes a load spread evenly over the face; the face and transverse load factors
(K_Fbeta, K_Falpha) carry the micro-geometry and misalignment, and the study reports those separately.
Spur pairs only: ISO rates a helical pair through its virtual spur gear, whose outer point of single
contact is not a position of the real helical mesh (the contact lines are inclined over the face).
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from gearopt.errors import OptionError

if TYPE_CHECKING:  # pragma: no cover
    from gearopt.fea.calculix import Deck
    from gearopt.fea.model import GearFEModel
    from gearopt.fea.result import FEResult
    from gearopt.gears import GearPair

#: the CI-sized mesh of the comparison (tests/test_fea.py's coarse mesh, ~5 s per ccx run on 2 cores)
COARSE_MESH = dict(n_face=2, n_half=4, n_flank=6, n_fillet=4, n_rim=3)
#: hertz elements across the contact half-width of the coarse mesh
COARSE_N_HERTZ = 2.0
#: the FE position is moved this share of the angular pitch from the outer point of single contact
#: toward the pitch point, so that the neighbouring pair (at the end of its path of contact there) is
#: certainly out of contact and the whole load is on the rated pair, as ISO assumes
INSIDE_SHARE = 0.01


def opsc_angle(pair: GearPair, member: int, d_en: float, n: int = 401) -> float:
    """Pinion angle phi1 [rad] (TCA convention, 0 at the pitch point) at which tooth pair 0 of the aligned,
    unmodified ``pair`` touches ``member`` (0 pinion, 1 gear) at the diameter ``d_en`` [mm], moved
    :data:`INSIDE_SHARE` of the angular pitch toward the pitch point (into single pair contact)."""
    from gearopt.fea.model import model_tca

    tca = model_tca(pair)
    pitch = 2 * math.pi / pair.pinion.z
    phis = np.linspace(-1.5 * pitch, 1.5 * pitch, n)
    res = tca.sweep(phis, pairs=[0])
    r = (res.radius1 if member == 0 else res.radius2)[0]
    ok = np.isfinite(r)
    x, y = phis[ok], r[ok]
    order = np.argsort(y)
    phi = float(np.interp(0.5 * d_en, y[order], x[order]))
    return phi - math.copysign(INSIDE_SHARE * pitch, phi)


def single_pair_deck(model: GearFEModel) -> Deck:
    """The CalculiX deck of ``model`` with the contact pair of tooth pair 0 only (ISO 6336-3's load case:
    the whole load on one pair); the other teeth stay in the mesh, without contact surfaces."""
    import dataclasses

    deck = model.deck()
    pair0 = deck.contact_pairs[model.tooth_ids.index(0)]
    return dataclasses.replace(deck, surfaces={k: v for k, v in deck.surfaces.items() if k in pair0},
                               contact_pairs=[pair0])


def run_single_pair(model: GearFEModel) -> FEResult:
    """Run ``model`` with :func:`single_pair_deck` (ccx) and read its results as :meth:`GearFEModel.run` does."""
    from gearopt.fea.calculix import run_ccx
    from gearopt.fea.result import FEResult

    deck = single_pair_deck(model)
    o = model.opt
    return FEResult.from_run(model, deck, run_ccx(deck, threads=o.threads, timeout=o.timeout, keep_dir=o.keep_dir))


def fe_root_stress(pair: GearPair, torque: float, d_en: tuple[float, float], sigma_F0: tuple[float, float],
                   progress: Any = None, mesh: dict | None = None, element_type: str = "C3D8") -> dict:
    """FE tooth-root stress of both members with the load at each one's outer point of single pair contact.

    Parameters
    ----------
    pair : GearPair
        The rated pair (spur); its micro-geometry is removed and the axes aligned for the FE model.
    torque : float
        Nominal pinion torque [N m].
    d_en : (float, float)
        ISO 6336-3's diameters of the outer point of single pair contact of pinion and gear [mm].
    sigma_F0 : (float, float)
        ISO's nominal root stress of pinion and gear [N/mm^2], for the gap.
    mesh : dict or None
        Element counts (:class:`gearopt.settings.MeshOptions` fields) replacing those of
        :data:`COARSE_MESH` (None: the coarse mesh).
    element_type : str
        ``"C3D8"`` or ``"C3D8I"`` (incompatible modes: free of the shear locking of C3D8 in bending, the
        root stress within 4 % of ISO's at ~7300 elements, docs/rating.md; ~3x the ccx time).

    Returns
    -------
    dict
        ``members`` (per member: ``phi1`` [rad], ``contact_diameter`` [mm] of the FE position,
        ``d_en`` [mm], ``sigma_FE`` [N/mm^2] the largest principal stress in the fillet within the
        middle half of the face, ``radius_at_max`` [mm], ``radius_30deg`` [mm] of ISO's critical
        section on the generated tooth, ``sigma_F0_iso`` [N/mm^2], ``gap_pct`` = 100 (sigma_FE /
        sigma_F0 - 1), ``loaded_pairs``, ``pair_force_N`` (the FE contact force of each tooth pair [N]: the
        rated pair 0 only), ``n_elements``, ``ccx_s`` [s]), ``mesh`` (the mesh options),
        ``run_s`` [s].

    Raises
    ------
    OptionError
        A helical pair (``fe_root``), an element type or element count out of its range.
    ArgumentError
        A ``mesh`` key that is not a field of :class:`gearopt.settings.MeshOptions`.
    CalculixError
        ccx missing (from :func:`gearopt.fea.calculix.require_ccx`) or a run that fails its checks.
    """
    from gearopt.fea.calculix import require_ccx
    from gearopt.fea.model import FEOptions, GearFEModel, model_tca
    from gearopt.rating.pair import reference_pair
    from gearopt.settings import MeshOptions

    require_spur(pair)
    # the options first (an unknown mesh key or element type names itself before anything runs)
    mesh_counts = {**COARSE_MESH, **(mesh or {})}
    opt = FEOptions(torque=1e3 * torque, n_hertz=COARSE_N_HERTZ, mesh=MeshOptions.of(**mesh_counts),
                    element_type=element_type)
    require_ccx()
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    ref = reference_pair(pair)
    tca = model_tca(ref)
    out = []
    for i, name in enumerate(("pinion", "gear")):
        phi1 = opsc_angle(ref, i, d_en[i])
        model = GearFEModel(ref, phi1, opt, tca=tca)
        say(f"rating: FE root stress of the {name} (load at its outer point of single pair contact, "
            f"{model.n_elements} elements); CalculiX running")
        d = run_single_pair(model).to_dict()
        root = d["root"][name]
        est = d["root_estimate"].get(name, {})
        c = d["contact_points"]["0"]
        s_fe = root["max_principal_mid"]
        out.append({"member": name, "phi1": phi1, "contact_diameter": 2 * c["radius1" if i == 0 else "radius2"],
                    "d_en": d_en[i], "sigma_FE": s_fe, "radius_at_max": root["radius_at_max_mid"],
                    "radius_30deg": est.get("radius_30deg"), "sigma_F0_iso": sigma_F0[i],
                    "gap_pct": 100.0 * (s_fe / sigma_F0[i] - 1.0), "loaded_pairs": d["loaded_pairs"],
                    "pair_force_N": d["pair_force_N"],
                    "n_elements": d["n_elements"], "ccx_s": d["timing"]["ccx_s"]})
    return {"members": out, "mesh": {**mesh_counts, "n_hertz": COARSE_N_HERTZ, "teeth": opt.teeth,
                                     "element_type": opt.element_type},
            "pair": "the rated pair without micro-geometry, aligned", "run_s": time.perf_counter() - t0}


def require_spur(pair: GearPair) -> None:
    """``fe_root = true`` needs a spur pair: ISO 6336-3 rates a helical pair through its virtual spur
    gear, whose outer point of single contact is no position of the real mesh.

    Raises
    ------
    OptionError
        A helical pair (naming ``fe_root``).
    """
    if not (pair.pinion.is_spur and pair.gear.is_spur):
        raise OptionError(f"fe_root = true: the FE root stress is compared with ISO 6336-3 for spur pairs only (this "
                          f"pair has beta = {math.degrees(pair.pinion.beta):.4g} deg: ISO rates a helical pair through "
                          "its virtual spur gear, whose outer point of single contact is no position of the real mesh). "
                          "Valid: fe_root = false for a helical pair.", param="fe_root", value=True,
                          valid="false for a helical pair")
