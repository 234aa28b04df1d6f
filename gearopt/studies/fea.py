"""Finite element study (Litvin section 9.5): contact pressure, root stresses and loaded rotation of
a spur/helical drive at a few positions of the meshing cycle, solved with CalculiX (``ccx``).

Scene section ``[fea]`` (torque in N*m; lengths mm): the model's options are declared once, by
:class:`gearopt.settings.FEOptions` and :class:`gearopt.settings.MeshOptions` (the API's
:mod:`gearopt.fea.model` takes them; ``gearopt studies fea`` and docs/scenes.md list the keys with their
defaults and ranges); the study's own keys are the pinion angles analysed (``phi1_start``,
``phi1_end``, ``n_positions``: TCA convention, 0 = tooth 0 at the pitch point, evenly spaced; one
position: ``phi1_start``), the misalignment of the gear (``dE``, ``crossing``, ``intersecting``,
``axial``: default aligned, placed as the TCA places it) and ``keep_files`` (keep the ccx input and
output in ``out/<scene name>_ccx/pos<i>``, relative to the cwd).

Each position is an independent ccx run; the study needs ``ccx`` on PATH (a clear error otherwise).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, ClassVar, Sequence, TYPE_CHECKING

import numpy as np

from ..summary import KeyNumber, fea_summary

if TYPE_CHECKING:  # pragma: no cover
    from ..fea.model import FEOptions, GearFEModel
    from ..gears import GearPair
    from ..io.scene import Scene
    from ..meshing.misalignment import Misalignment

UNITS = {"length": "mm", "angle": "rad", "stress": "MPa", "force": "N", "torque": "N*mm (input: N*m)",
         "te": "arcsec (suffix _arcsec)", "time": "s"}


@dataclass
class FEReport:
    scene: str
    pair: dict
    options: dict
    positions: list
    mesh_plot: dict
    timing: dict = field(default_factory=dict)
    fe_results: list = field(default_factory=list, repr=False)  # FEResult per position (for the .vtu files)

    def to_dict(self) -> dict:
        return {"study": "fea", "scene": self.scene, "units": UNITS, "pair": self.pair, "options": self.options,
                "positions": self.positions, "mesh": self.mesh_plot, "timing": self.timing}

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """``fea_<i>.vtu`` per position i (0, 1, ...): the model with displacements, stresses (von Mises)
        and contact pressure for ParaView (meshio)."""
        files = []
        for i, r in enumerate(self.fe_results):
            name = f"fea_{i}.vtu"
            r.write_vtu(Path(out_dir) / name)
            files.append(name)
        return files

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "fea_mesh.png": "The FE model's middle transverse section at the first position, with the contact zone "
                        "enlarged: read whether the mesh resolves the Hertz half-width.",
        "fea_contact.png": "Contact pressure along the pinion profile through the contact point, FE against Hertz, at "
                           "each position: read the peak pressure and how closely the FE follows Hertz.",
        "fea_pattern.png": "Load per mm of face of each loaded tooth pair across the face: read how evenly the face "
                           "carries the load (misalignment moves it to one end).",
        "fea_root.png": "Largest principal root stress of pinion and gear (left axis) and the peak contact pressure "
                        "(right axis) at the analysed positions, with the ISO 6336-3 estimate: read the highest root "
                        "stress and where in the mesh it occurs.",
        "fea_te.png": "Loaded transmission error of the FE model at the analysed positions: read the difference "
                      "between single- and double-pair contact (the loaded TE variation).",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.fea_summary`), read from :meth:`to_dict`."""
        return fea_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``fea_mesh.png`` (transverse section of the model at the first position, element edges),
        ``fea_contact.png`` (contact pressure along the profile at mid face vs Hertz),
        ``fea_root.png`` (root stress and pressure vs position), ``fea_te.png`` (loaded TE vs
        position), ``fea_pattern.png`` (load per mm of face of each loaded pair across the face)."""
        import matplotlib.pyplot as plt

        from ..plot.fea import plot_contact_pressure, plot_line_load, plot_loaded_te, plot_mesh, plot_root_stress
        from ..plot.saving import drawn_here

        out = Path(out_dir)
        d = self.to_dict()

        def save(name, fig):
            fig.tight_layout()
            fig.savefig(out / name, dpi=dpi, bbox_inches="tight")
            plt.close(fig)

        # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
        if drawn_here(out / "fea_mesh.png"):
            fig, axes = plt.subplots(1, 2, figsize=(13, 6))
            plot_mesh(d, ax=axes[0])
            plot_mesh(d, ax=axes[1], zoom=True)
            save("fea_mesh.png", fig)
        for name, plot, size in (("fea_contact.png", plot_contact_pressure, (9, 5)),
                                 ("fea_root.png", plot_root_stress, (8, 4.5)),
                                 ("fea_te.png", plot_loaded_te, (8, 4.5)),
                                 ("fea_pattern.png", plot_line_load, (9, 5))):
            if drawn_here(out / name):
                fig, ax = plt.subplots(figsize=size)
                plot(d, ax=ax)
                save(name, fig)
        return ["fea_mesh.png", "fea_contact.png", "fea_root.png", "fea_te.png", "fea_pattern.png"]


def mesh_section(model: GearFEModel, layer: int | None = None) -> dict:
    """Element edges of the middle transverse section of the model (S_f, mm) for plotting:
    ``{"pinion": [[x0, y0, x1, y1], ...], "gear": [...]}`` plus the contact points."""
    out = {}
    for name, mesh, X in (("pinion", model.pinion_mesh, model.nodes_pinion), ("gear", model.gear_mesh, model.nodes_gear)):
        segs = []
        for t in mesh.teeth:
            nd = t["nodes"]
            L = nd.shape[0] // 2 if layer is None else layer
            G = X[nd[L]][..., :2]  # (rows, cols, 2)
            for a, b in ((G[:-1, :], G[1:, :]), (G[:, :-1], G[:, 1:])):
                segs.append(np.concatenate([a.reshape(-1, 2), b.reshape(-1, 2)], axis=1))
        out[name] = np.round(np.vstack(segs), 5).tolist()
    r = model.tca_result
    out["contact_points"] = [[float(v) for v in r.rf[i, 0, :2]] for i, k in enumerate(model.tooth_ids) if k in model.loaded]
    out["hertz_b"] = model.b_H
    return out


class FEStudy:
    def __init__(self, pair: GearPair, options: FEOptions, phi1s: Sequence[float], name: str = "fea",
                 keep_dir: str | Path | None = None, misalignment: Misalignment | None = None) -> None:
        from ..meshing.misalignment import Misalignment

        self.pair, self.options, self.phi1s, self.name, self.keep_dir = pair, options, list(phi1s), name, keep_dir
        self.misalignment = misalignment or Misalignment()

    def run(self, progress: Callable[[str], None] | None = None) -> FEReport:
        from dataclasses import replace

        from ..fea.calculix import require_ccx
        from ..fea.model import GearFEModel, model_tca
        from ..progress import heartbeat
        from ..report import misalignment_dict

        require_ccx()
        t0 = time.perf_counter()
        p = self.pair
        tca = model_tca(p, self.misalignment)
        positions, mesh_plot, fe_results = [], None, []
        n = len(self.phi1s)
        for i, phi1 in enumerate(self.phi1s):
            tag = f"fea: position {i + 1}/{n}"
            if progress:
                progress(f"{tag} (phi1 = {math.degrees(phi1):.3f} deg): building the model")
            t1 = time.perf_counter()
            opt = self.options
            if self.keep_dir is not None:
                opt = replace(opt, keep_dir=str(Path(self.keep_dir) / f"pos{i}"))
            model = GearFEModel(p, phi1, opt, tca=tca, mis=self.misalignment)
            if mesh_plot is None:
                mesh_plot = mesh_section(model)
            if progress:
                nodes = len(model.nodes_pinion) + len(model.nodes_gear)
                elements = len(model.pinion_mesh.elements) + len(model.gear_mesh.elements)
                progress(f"{tag}: {nodes} nodes, {elements} elements ({model.build_time:.1f} s); CalculiX running")
            with heartbeat(progress, f"{tag}: CalculiX running", every=15.0):
                res = model.run()
            if progress:
                progress(f"{tag}: done in {time.perf_counter() - t1:.1f} s")
            fe_results.append(res)
            positions.append(res.to_dict())
        o = self.options
        pair = {"z1": p.pinion.z, "z2": p.gear.z, "m_n": p.pinion.m_n, "a": p.a_w, "b1": p.pinion.b, "b2": p.gear.b,
                "r_b1": p.pinion.r_b, "r_b2": p.gear.r_b, "eps_alpha": p.eps_alpha, "contact": tca.contact_type}
        return FEReport(scene=self.name, pair=pair, options={**o.to_dict(), "misalignment":
                                                                   misalignment_dict(self.misalignment)},
                        positions=positions, mesh_plot=mesh_plot,
                        timing={"run_s": time.perf_counter() - t0}, fe_results=fe_results)


def _check_positions(scene: Scene, phis: Sequence[float], teeth: int, mis: Misalignment | None = None) -> None:
    """Before running: every FE position must have a tooth pair of the modelled ones in contact on
    the active flanks (the same TCA the model uses), else a SceneError naming phi1_start/phi1_end."""
    from ..errors import ConvergenceError
    from ..fea.model import model_tca

    p = scene.pair
    tca = model_tca(p, mis)
    ids = tuple(range(-(teeth // 2), teeth - teeth // 2))
    phis = np.asarray(phis, float)
    misaligned = mis is not None and bool(np.any(mis.vector() != 0))
    try:
        on = tca.sweep(phis, pairs=ids, mis=mis if misaligned else None).on_surface.any(axis=0)
    except ConvergenceError:
        on = np.zeros(phis.size, bool)
    if on.all():
        return
    i = int(np.flatnonzero(~on)[0])
    key = "phi1_end" if (i == phis.size - 1 and phis.size > 1) else "phi1_start"
    pitch = 360.0 / p.pinion.z
    raise scene.key_error("fea", key, f"is out of range: at phi1 = {math.degrees(phis[i]):.4g} deg none of the {teeth} "
                          f"modelled tooth pairs is in contact on the active flanks (one mesh cycle is 360 / z1 = "
                          f"{pitch:.4g} deg; phi1 = 0 puts tooth 0 at the pitch point). Choose positions within the "
                          "meshing of the modelled teeth or model more teeth"
                          + (f"; or reduce the misalignment ({mis.label()}): under it the contact may leave the "
                             "flanks (edge contact), unless the pinion is crowned." if misaligned else "."))


def _from_scene(scene: Scene) -> FEStudy:
    from ..errors import GeometryError, OptionError
    from ..settings import FEOptions, MeshOptions
    from .tca import check_misalignment_keys, misalignment_from

    o = scene.options.get("fea", {}) or {}
    check_misalignment_keys(scene, "fea", o, signs=(1,))
    mis = misalignment_from(o)
    try:
        opt = FEOptions.from_scene(o, torque=o["torque"] * 1e3, mesh=MeshOptions.from_scene(o))
    except (GeometryError, OptionError) as e:
        raise scene.study_error("fea", e) from e
    n = o["n_positions"]
    a, b = o["phi1_start"], o["phi1_end"]
    if n > 1 and a == b:
        raise scene.key_error("fea", "n_positions", f"is out of range; valid: n_positions = 1 when phi1_start = "
                              f"phi1_end ({n} positions at the same angle would repeat one FE run), or give "
                              "phi1_end another angle.", valid="n_positions = 1 when phi1_start = phi1_end")
    if n == 1 and a != b and scene.written("fea", "phi1_end") is not None:
        raise scene.key_error("fea", "phi1_end", "is not used with n_positions = 1 (only phi1_start is analysed); "
                              "valid: n_positions >= 2 to analyse phi1_start to phi1_end, or leave phi1_end out.",
                              valid="n_positions >= 2")
    phis = [a] if n == 1 else list(np.linspace(a, b, n))
    _check_positions(scene, phis, opt.teeth, mis)
    keep = None
    if o.get("keep_files"):
        keep = Path("out") / f"{scene.name}_ccx"
    return FEStudy(scene.pair, opt, phis, name=scene.name, keep_dir=keep, misalignment=mis)


def _register() -> None:
    from ..schema import Bounds, Field
    from ..settings import FEOptions, MeshOptions
    from . import StudySpec, register
    from .tca import misalignment_fields

    # the scene's torque is in N*m, the API's (FEOptions.torque) in N*mm: its default and range from there
    torque, torque_default = FEOptions.options()["torque"]
    b = torque.bounds
    register(StudySpec(
        name="fea",
        doc="Finite element model (Litvin 9.5) solved with CalculiX: contact pressure vs Hertz, root stress, loaded TE",
        sections=[FEOptions.section("fea", [
            Field("torque", "float", default=torque_default / 1e3,
                  check=Bounds(lo=b.lo / 1e3, lo_open=b.lo_open, hi=b.hi / 1e3, hi_open=b.hi_open),
                  doc="pinion torque [N*m]"),
            "E", "nu",
            Field("phi1_start", "angle", default=0.0, check=Bounds(lo=-60, hi=60),
                  doc="first pinion angle (0: tooth 0 at the pitch point)"),
            Field("phi1_end", "angle", default=0.0, check=Bounds(lo=-60, hi=60), doc="last pinion angle"),
            Field("n_positions", "int", default=1, check=Bounds(lo=1, hi=50), doc="positions from phi1_start to phi1_end"),
            "teeth", "n_hertz",
            *MeshOptions.scene_fields(["n_face", "n_half", "n_flank", "n_fillet", "n_rim", "rim_depth"]),
            "penalty",
            Field("keep_files", "bool", default=False, doc="keep the ccx files (out/<scene name>_ccx/pos<i>)"),
            *misalignment_fields(suffix="; placed as in the TCA"),
        ], required=False)],
        settings=(FEOptions, MeshOptions),
        build=_from_scene,
    ))


_register()
