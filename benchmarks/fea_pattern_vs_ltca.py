"""The FE contact pattern of a misaligned crowned spur pinion against the loaded TCA's
(tests/test_fea.py::test_misaligned_crowned_pattern_moves_as_loaded_tca_predicts), per mesh.

    python benchmarks/fea_pattern_vs_ltca.py           # three meshes, about 4 minutes of CPU (2 cores)
    python benchmarks/fea_pattern_vs_ltca.py --quick   # the test's mesh only (about 40 s of CPU)

Drive: 20/40, m 3 mm, b 20 mm, pinion a_pl 0.0004 1/mm, a_c 0.002 1/mm (problems/fea_crowned.toml),
3 arcmin crossing, 200 N*m, pitch point (phi1 = 0, one pair loaded). Prints per mesh: elements, the
CPU seconds of ccx, the centroid of the FE line load across the face [mm] (nodal contact pressure
integrated over the flank, gearopt.fea), its distance to the loaded TCA's centroid (analytical
compliance, gearopt.ltca) and the nodal pressures' integral over the contact force. The test asserts
the distance < 0.5 mm on the first mesh.
"""

from __future__ import annotations

import resource
import shutil
import sys

import numpy as np

from gearopt.fea import FEOptions, GearFEModel, MeshOptions
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.compliance import Material
from gearopt.ltca.engine import LTCA
from gearopt.meshing.misalignment import Misalignment
from gearopt.units import ARCMIN

#: (n_face, n_half, n_flank, n_fillet, n_rim): the test's mesh first
MESHES = [(16, 2, 4, 2, 2), (8, 4, 6, 4, 3), (16, 4, 6, 4, 3)]


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed: nothing to benchmark")
        return
    quick = "--quick" in sys.argv[1:]
    pair = GearPair(Gear(z=20, m_n=3, b=20, a_pl=4e-4, rack=BasicRack.iso53("A", a_c=2e-3), name="pinion"),
                    Gear(z=40, m_n=3, b=20, name="gear"))
    mis, T = Misalignment(crossing=3 * ARCMIN), 200.0
    L = LTCA(pair, material=Material(E=210e3, nu=0.3))
    S = L.slices(phi1=np.array([0.0]), mis=mis)
    r = L.solve(T, slices=S).results[0]
    kk = r.pairs.index(0)
    ok = np.isfinite(S.z[kk, 0]) & (S.edge[kk, 0] == 0)
    F = r.load[kk, 0][ok]
    zc_lt = float((F * S.z[kk, 0][ok]).sum() / F.sum())
    print(f"loaded TCA centroid: {zc_lt:.3f} mm")
    print(f"{'n_face/half/flank/fillet/rim':>28} {'elements':>8} {'ccx CPU s':>9} {'FE centroid mm':>14} "
          f"{'FE - LTCA mm':>12} {'nodal/force':>11}")
    for mesh in MESHES[:1] if quick else MESHES:
        nf, nh, nfl, nfi, nr = mesh
        opts = dict(n_hertz=2.0, mesh=MeshOptions(n_face=nf, n_half=nh, n_flank=nfl, n_fillet=nfi, n_rim=nr))
        model = GearFEModel(pair, 0.0, FEOptions(torque=T * 1e3, **opts), mis=mis)
        c0 = children_cpu()
        d = model.run().to_dict()
        pat = d["contact"]["pattern"]["0"]
        print(f"{'/'.join(map(str, mesh)):>28} {len(model.deck().elements):8d} {children_cpu() - c0:9.1f} "
              f"{pat['z_centroid']:14.3f} {pat['z_centroid'] - zc_lt:12.3f} {pat['nodal_over_force']:11.3f}", flush=True)


if __name__ == "__main__":
    main()
