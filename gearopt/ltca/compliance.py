"""Tooth compliance of the analytical thin-slice model of loaded TCA (docs/ltca.md, section 2).

A tooth pair in mesh is cut into transverse slices across the face. The deflection of a slice
along the contact normal is the sum of

* bending, shear and radial compression of each tooth as a cantilever of variable thickness
  clamped at the root circle (Weber 1949; the energy form of Cornell 1981, plane strain),
  integrated over the member's own generated transverse section (flank and fillet, as cut by
  its tool: :meth:`~gearopt.geometry.generation.GeneratedTooth.transverse_profile`);
* the gear-body (fillet-foundation) term in the form of Sainsot, Velex & Duverger (2004), with
  coefficients refitted to plane-stress FE full gears held at their bores (:data:`FULL_GEAR_FIT`,
  ``benchmarks/fe_body_fit.py``; their own coefficients, :data:`SAINSOT`, with ``body =
  "sainsot2004"``);
* the local contact approach of Weber & Banaschek (1953) for two cylinders in line contact,
  measured to the tooth centrelines (nonlinear in the load);

and the slices of one tooth pair are coupled across the face by the discrete Green's function of
``w - lambda^2 w'' = c f`` with free face ends (a Pasternak foundation), one for each part with its
own length: the teeth (bending, shear, compression) over ``lambda`` = half the tooth height, each
member's body (the foundation term) over the body's depth under the root, ``r_f - r_int``
(:func:`face_matrix_batch`, :func:`body_coupling_length`). A load uniform over the face deflects
every slice by the plane-strain value ``c f``; a concentrated load spreads each part over about
``2 lambda`` of its own. Different tooth pairs are coupled through the bodies by
:mod:`gearopt.ltca.neighbours` (``LTCASettings.neighbours``).

A helical slice is the transverse section; ``LTCA.structure`` projects its compliance on the normal with
``cos^2(beta_b)``. With ``helical = "normal"`` (the default) the teeth's terms are divided by ``cos(beta_b)``
and the body's by ``cos^2(beta_b)`` first, so that along the normal the teeth give ``cos(beta_b) c`` and the
body its transverse term, as the FE full gears of docs/ltca.md section 7 do.

Units: mm, N, MPa. A compliance per unit face width ``c`` [mm^2/N] gives the deflection [mm] of
a line load [N/mm].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..contact.hertz import contact_modulus, hertz_half_width, hertz_peak_pressure, weber_compliance
from ..errors import OptionError, check_number, out_of_range
from ..geometry.generation import GeneratedTooth
from .plate import rim_flexibility

if TYPE_CHECKING:
    from ..gears import GearPair

#: Sainsot, Velex & Duverger (2004), Table 1: coefficients (A, B, C, D, E, F) of
#: ``X = A / theta_f^2 + B h_fi^2 + C h_fi / theta_f + D / theta_f + E h_fi + F`` for X = L, M, P, Q.
SAINSOT = {
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}
#: Sainsot's form refitted to plane-stress FE full gears held at their bores (``python benchmarks/fe_body_fit.py``,
#: benchmarks/data/fe_body_fit.json "fit"; docs/ltca.md section 2): (A, B, C, D, E, F) as in :data:`SAINSOT`
FULL_GEAR_FIT = {
    "L": (-0.0020638671, -0.0023743527, -0.0014725576, 0.032304562, 0.091524566, 4.7190922),
    "M": (-0.000733008, -0.065105097, -0.07464273, 0.13578915, 1.8187467, -2.018936),
    "P": (-0.0023697979, 0.11815735, -0.0017226827, 0.1172066, 0.80993175, -0.73684653),
    "Q": (0.0024626774, 0.076810368, -0.0074923544, -0.040982144, -0.55951671, 1.4454141),
}
#: the range of ``theta_f`` [rad] of the FE gears :data:`FULL_GEAR_FIT` was fitted to (80 and 14 teeth): outside it
#: the polynomials take the nearer end (1/theta_f^2 terms do not extrapolate; the FE body per unit face width at
#: one bore ratio changes by a few percent from 40 to 80 teeth, docs/ltca.md section 2)
FULL_GEAR_FIT_THETA = (0.037661, 0.215206)
#: the body terms by name (``LTCASettings.body``): the coefficients of Sainsot's polynomials
BODY_TERMS = {"full_gear_fit": FULL_GEAR_FIT, "sainsot2004": SAINSOT}
#: how a helical tooth's transverse compliance enters the normal one (``LTCASettings.helical``)
HELICAL = ("normal", "transverse")
H_FI_RANGE = (1.4, 7.0)  #: r_f / r_int range of Sainsot's fit and of the refit to FE full gears
SHEAR_FACTOR = 1.2  #: shear correction of a rectangular section (energy method)


@dataclass(frozen=True)
class Material:
    """Elastic constants of both members (same material).

    Parameters
    ----------
    E : float
        Young's modulus [MPa] (steel 206000), 500 <= E <= 1.2e6.
    nu : float
        Poisson's ratio, 0 < nu < 0.5.
    """

    E: float = 206000.0
    nu: float = 0.3

    def __post_init__(self):
        E = check_number("E", self.E, "Young's modulus [MPa]")
        if not 500.0 <= E <= 1.2e6:
            raise out_of_range("E", E, "500 <= E <= 1.2e6 MPa, the Young's moduli of gear materials (steel 206000 MPa)")
        nu = check_number("nu", self.nu, "Poisson's ratio")
        if not 0.0 < nu < 0.5:
            raise out_of_range("nu", nu, "0 < nu < 0.5 (steel 0.3)")

    @property
    def E_plane(self) -> float:
        """Plane-strain modulus E / (1 - nu^2) [MPa]."""
        return self.E / (1.0 - self.nu**2)

    @property
    def E_star(self) -> float:
        """Contact modulus of the pair, ``1/E* = 2 (1 - nu^2) / E`` [MPa]."""
        return contact_modulus(self.E, self.nu)


@dataclass(frozen=True)
class SliceCompliance:
    """The compliances per unit face width of a tooth for loads at points of its flank
    (:meth:`ToothCompliance.per_width`), (M,) arrays, one entry per point."""

    bending: np.ndarray  #: bending of the tooth as a beam [mm^2/N]
    shear: np.ndarray  #: its shear [mm^2/N]
    compression: np.ndarray  #: its compression along the centreline [mm^2/N]
    foundation: np.ndarray  #: the body's rotation and translation (Sainsot's foundation) [mm^2/N]
    total: np.ndarray  #: the sum of the four [mm^2/N]
    h: np.ndarray  #: distance from the load point to the centreline along the load line [mm] (Weber's term)
    eta_F: np.ndarray  #: height above the root circle where the load line crosses the centreline [mm]


class ToothCompliance:
    """Bending, shear, compression and foundation compliance of one member's tooth per unit face
    width, for a load anywhere on its flank (transverse plane).

    Parameters
    ----------
    tooth : GeneratedTooth
        The member's generated tooth (its transverse section at mid face is the beam).
    material : Material
    r_int : float
        Inner radius of the gear body [mm], where it is held (the bore); both fits cover
        ``1.4 <= r_f / r_int <= 7``. The body deflects more the deeper it is (its
        bore is the fixed reference).
    member : str
        "pinion" or "gear" (for messages).
    n : int
        Points of the beam quadrature.
    body : {"full_gear_fit", "sainsot2004"}
        The body term's coefficients: :data:`FULL_GEAR_FIT` (Sainsot's form refitted to FE full gears
        held at their bores, docs/ltca.md section 2) or Sainsot et al.'s own, :data:`SAINSOT`.
    helical : {"normal", "transverse"}
        For a helical member (``beta_b > 0``): ``"normal"`` divides the teeth's terms by ``cos(beta_b)``
        and the body's by ``cos^2(beta_b)`` (the values are transverse compliances that loaded TCA
        multiplies by ``cos^2(beta_b)``), the body with its axial part (:meth:`axial`, (N2) of
        docs/ltca.md section 2); ``"transverse"`` leaves them. A spur member: no difference.

    Raises
    ------
    GeometryError
        ``r_int`` outside ``r_f / 7 <= r_int <= r_f / 1.4`` (the range of both fits).
    OptionError
        ``body`` or ``helical`` not one of the names above.
    """

    def __init__(self, tooth: GeneratedTooth, material: Material, r_int: float, n: int = 600,
                 member: str = "gear", body: str = "full_gear_fit", helical: str = "normal"):
        if body not in BODY_TERMS:
            raise out_of_range("body", body, " or ".join(repr(k) for k in BODY_TERMS), cls=OptionError)
        if helical not in HELICAL:
            raise out_of_range("helical", helical, " or ".join(repr(k) for k in HELICAL), cls=OptionError)
        self.body = body
        self.helical = helical
        # LTCA.structure projects these transverse compliances on the normal with cos^2(beta_b). The FE full
        # gears (docs/ltca.md section 7) give a helical member's teeth cos(beta_b) c_teeth and its body the
        # transverse term itself along the normal, per unit face width: the factors that make the projection so
        cb = math.cos(float(tooth.gear.beta_b))
        self.teeth_factor = 1.0 / cb if helical == "normal" else 1.0
        self.body_factor = 1.0 / cb**2 if helical == "normal" else 1.0
        self.material = material
        pr = tooth.transverse_profile(z=0.0, n=n // 2)
        P = np.vstack([pr["right_flank"], pr["right_fillet"][1:]])
        # the root circle and the angle where the fillet reaches it (Sainsot's theta_f)
        end = pr["right_fillet"][-1]
        self.r_f = float(np.hypot(*end))
        self.theta_f = float(math.atan2(abs(end[0]), end[1]))
        lo, hi = self.r_f / H_FI_RANGE[1], self.r_f / H_FI_RANGE[0]
        if not lo <= r_int <= hi:
            raise out_of_range(f"{member}.r_int", r_int, f"{lo:.6g} <= r_int <= {hi:.6g} mm (inner radius of the "
                               f"gear body: the body term (Sainsot's form) is fitted for {H_FI_RANGE[0]} <= r_f / r_int <= "
                               f"{H_FI_RANGE[1]}, r_f = {self.r_f:.6g} mm)")
        self.r_int = float(r_int)
        self.h_fi = self.r_f / self.r_int
        self.S_f = 2.0 * self.r_f * math.sin(self.theta_f)
        th = self.theta_f if body == "sainsot2004" else float(np.clip(self.theta_f, *FULL_GEAR_FIT_THETA))
        coef = {k: a / th**2 + b * self.h_fi**2 + c * self.h_fi / th + d / th + e * self.h_fi + f
                for k, (a, b, c, d, e, f) in BODY_TERMS[body].items()}
        self.sainsot = coef
        # half thickness x(y) along the tooth centreline (the +y axis), from the root circle up
        y, x = P[:, 1], np.abs(P[:, 0])
        order = np.argsort(y)
        y, x = y[order], x[order]
        self.y_tip = float(y[-1])
        eta = np.linspace(0.0, self.y_tip - self.r_f, n)  # height above the root circle
        xe = np.interp(eta + self.r_f, y, x)
        w3 = 1.0 / (2.0 * xe) ** 3
        w1 = 1.0 / (2.0 * xe)

        def cum(f):
            return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(eta))])

        self._eta = eta
        self._I = [cum(w3), cum(eta * w3), cum(eta**2 * w3)]
        self._J = cum(w1)
        # the axial part of a helical member's normal load (helical = "normal"): sin^2(beta_b) of it bends the
        # body out of its plane, the annular Mindlin plate of gearopt.ltca.plate (thickness b, held at r_int,
        # free at r_f) loaded through the tooth at the load point's radius; per unit line load over the face
        # b (F11 - 2 h F12 + h^2 F22), h the lever above r_f (docs/ltca.md section 2, (N2))
        g = tooth.gear
        self.axial_share = math.sin(float(g.beta_b)) ** 2 if helical == "normal" else 0.0
        self._axial_F = None
        if self.axial_share > 0.0:
            F = rim_flexibility(self.r_int, self.r_f, float(g.b), [0.0], spread=float(g.b) * math.tan(abs(float(g.beta)))
                                / float(g.r_p), E=material.E, nu=material.nu)[0]
            self._axial_F = float(g.b) * F

    def axial(self, radius: npt.ArrayLike) -> np.ndarray:
        """The body's axial compliance [mm^2/N] under an axial line load over the face at ``radius`` [mm] (the
        annular plate, read where it is loaded; zeros where the member has no axial part)."""
        r = np.asarray(radius, float)
        if self._axial_F is None:
            return np.zeros_like(r)
        h = np.maximum(r - self.r_f, 0.0)
        F = self._axial_F
        return F[0, 0] - 2.0 * h * F[0, 1] + h**2 * F[1, 1]

    def per_width(self, xy: npt.ArrayLike, n_xy: npt.ArrayLike, axial: bool = True) -> SliceCompliance:
        """Compliances per unit face width [mm^2/N] for loads at points of the flank.

        Parameters
        ----------
        xy : (M, 2) array
            Load points in the tooth's transverse frame (tooth centred on +y) [mm].
        n_xy : (M, 2) array
            Outward flank normals there (transverse components; normalised here).
        axial : bool
            Whether the body term carries a helical member's axial part (:meth:`axial`): ``foundation`` is then
            ``body_factor ((1 - q) c_t + q a)``, ``q = sin^2(beta_b)``, ``c_t`` the in-plane term; else ``body_factor
            c_t`` (the in-plane body alone, as (N1) takes it).

        Returns
        -------
        SliceCompliance
            (M,) arrays ``bending``, ``shear``, ``compression``, ``foundation``, ``total`` [mm^2/N],
            and ``h`` [mm], the distance from the load point to the centreline along the load line
            (Weber's contact term), ``eta_F`` [mm], the height above the root circle where the
            load line crosses the centreline.
        """
        xy = np.atleast_2d(np.asarray(xy, float))
        nv = np.atleast_2d(np.asarray(n_xy, float))
        nv = nv / np.linalg.norm(nv, axis=1, keepdims=True)
        xP, yP = np.abs(xy[:, 0]), xy[:, 1]
        nx, ny = np.abs(nv[:, 0]), nv[:, 1]
        cos_g, sin_g = nx, np.abs(ny)
        # the load -n meets the centreline at y_F (above the point: the outward normal points down)
        yF = yP - xP * ny / nx
        etaP = np.clip(yP - self.r_f, 0.0, self._eta[-1])
        etaF = yF - self.r_f
        I0, I1, I2 = (np.interp(etaP, self._eta, Ik) for Ik in self._I)
        J = np.interp(etaP, self._eta, self._J)
        m = self.material
        kt = self.teeth_factor
        bend = kt * cos_g**2 / m.E_plane * 12.0 * (etaF**2 * I0 - 2.0 * etaF * I1 + I2)
        shear = kt * cos_g**2 * SHEAR_FACTOR * 2.0 * (1.0 + m.nu) / m.E * J
        comp = kt * sin_g**2 / m.E_plane * J
        c = self.sainsot
        ratio = etaF / self.S_f
        found = cos_g**2 / m.E * (c["L"] * ratio**2 + c["M"] * ratio + c["P"] * (1.0 + c["Q"] * (sin_g / cos_g) ** 2))
        q = self.axial_share if axial else 0.0
        if q > 0.0:
            found = (1.0 - q) * found + q * self.axial(np.hypot(xy[:, 0], xy[:, 1]))
        found = self.body_factor * found
        return SliceCompliance(bending=bend, shear=shear, compression=comp, foundation=found,
                               total=bend + shear + comp + found, h=xP / cos_g, eta_F=etaF)


class WeberContact(NamedTuple):
    """Weber & Banaschek's contact approach and the Hertz values at a load (:func:`weber_contact`)."""

    compliance: np.ndarray  #: ``delta / f`` [mm^2/N] (per unit contact length)
    b_H: np.ndarray  #: Hertz half-width [mm]
    p0: np.ndarray  #: Hertz peak pressure [MPa]


def weber_contact(f: npt.ArrayLike, R_star: npt.ArrayLike, h1: npt.ArrayLike, h2: npt.ArrayLike, material: Material,
                  f_min: float) -> WeberContact:
    """Weber & Banaschek's contact approach of two cylinders in line contact, each measured to
    depth ``h`` (the tooth centreline) [mm], and the Hertz values.

    ``delta = 2 f (1 - nu^2) / (pi E) (ln(2 h1 / b_H) + ln(2 h2 / b_H) - nu / (1 - nu))`` with the
    Hertz half-width ``b_H = sqrt(4 f R* / (pi E*))``, peak pressure ``p0 = sqrt(f E* / (pi R*))``.

    Parameters
    ----------
    f : array
        Load per unit length of contact line [N/mm]; values below ``f_min`` use ``f_min`` for the
        logarithm (the compliance stays finite at vanishing load).
    R_star : array
        Reduced radius of curvature across the contact line [mm].

    Returns
    -------
    WeberContact
        ``compliance``: ``delta / f`` [mm^2/N] (per unit contact length); ``b_H``, ``p0``: arrays
        [mm], [MPa] at the load ``f``.
    """
    f = np.asarray(f, float)
    Es = material.E_star
    c = weber_compliance(f, R_star, h1, h2, material.E, material.nu, Es, f_min, smoothing="max")
    fp = np.maximum(f, 0.0)
    return WeberContact(compliance=c, b_H=hertz_half_width(fp, R_star, Es), p0=hertz_peak_pressure(fp, R_star, Es))


def weber_tangent(material: Material) -> ca.Function:
    """Weber's contact compliance and its tangent, elementwise: ``(f, R_star, h1, h2, f_min) ->
    (c, dc)`` with ``c = delta / f`` as :func:`weber_contact` [mm^2/N] and ``dc = d(c f)/df`` (the
    approach's derivative by AD; the Newton step of the Hertz fixed point, docs/ltca.md section 3)."""
    f, R, h1, h2, f_min = (ca.SX.sym(n) for n in ("f", "R_star", "h1", "h2", "f_min"))
    c = weber_compliance(f, R, h1, h2, material.E, material.nu, material.E_star, f_min, smoothing="max")
    return ca.Function("weber_tangent", [f, R, h1, h2, f_min], [c, ca.jacobian(c * f, f)],
                       ["f", "R_star", "h1", "h2", "f_min"], ["c", "dc"])


def weber_tangent_array(f: npt.ArrayLike, R_star: npt.ArrayLike, h1: npt.ArrayLike, h2: npt.ArrayLike,
                        material: Material, f_min: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`weber_tangent` on numpy arrays (elementwise, any common shape): ``(c, dc)`` [mm^2/N] with
    ``c = delta / f`` as :func:`weber_contact` and ``dc = d(c f)/df = c + f dc/df``; the logarithm's
    derivative is ``dc/df = -2 (1 - nu^2) / (pi E f)`` above ``f_min`` and 0 below it (where ``c`` is
    held at its value at ``f_min``)."""
    f = np.asarray(f, float)
    m = material
    c = weber_compliance(f, R_star, h1, h2, m.E, m.nu, m.E_star, f_min, smoothing="max")
    slope = np.where(f > f_min, -2.0 * (1.0 - m.nu**2) / (math.pi * m.E) / np.maximum(f, f_min), 0.0)
    return c, c + f * slope


def coupling(z: npt.ArrayLike, widths: npt.ArrayLike, lam: float) -> np.ndarray:
    """Discrete Green's function of ``w - lam^2 w'' = f`` on the face with free ends [1/mm].

    Nodes ``z`` (ascending) [mm] with tributary ``widths`` [mm]; linear elements between nodes.
    ``A = diag(widths) + lam^2 K`` (K: stiffness of the elements); returns ``A^-1`` (symmetric
    positive definite), so that nodal forces F give deflections ``c A^-1 F`` and a uniform line
    load ``f`` (``F = widths f``) gives exactly ``c f`` at every node.
    """
    z = np.asarray(z, float)
    return coupling_batch(z[None, :], np.asarray(widths, float)[None, :], lam)[0]


def coupling_batch(z: np.ndarray, widths: np.ndarray, lam: float) -> np.ndarray:
    """:func:`coupling` of many slice rows at once: ``z``, ``widths`` (B, M) [mm], each row's used
    nodes first (unused: ``z`` NaN); returns (B, M, M) with zero rows/columns at unused nodes."""
    z = np.asarray(z, float)
    widths = np.asarray(widths, float)
    used = np.isfinite(z)
    # rows of one grid repeat (the slices are fixed to the tooth): each distinct row inverted once (rows
    # compared by their bytes, one void item per row: 0.04 instead of 0.33 ms for np.unique(axis=0) on 96
    # rows; rows of equal bytes have equal matrices, so the same inverse bit for bit)
    key = np.ascontiguousarray(np.concatenate([np.where(used, z, np.inf),
                                               np.where(np.isfinite(widths), widths, -np.inf)], axis=1))
    rows = key.view(np.dtype((np.void, key.itemsize * key.shape[1]))).ravel()
    uniq, first, inv = np.unique(rows, return_index=True, return_inverse=True)
    if uniq.shape[0] < z.shape[0]:
        G = np.linalg.inv(coupling_stiffness_batch(z[first], widths[first], lam))[inv.ravel()]
    else:
        G = np.linalg.inv(coupling_stiffness_batch(z, widths, lam))
    return np.where(used[:, :, None] & used[:, None, :], G, 0.0)


def face_matrix_batch(z: np.ndarray, widths: np.ndarray, terms: list[tuple[np.ndarray, float]]) -> np.ndarray:
    """Compliance blocks of slice rows coupled across the face, one Pasternak coupling per term:
    ``sum_k D_k A_k^-1 D_k`` with ``D_k = diag(sqrt(c_k))`` and ``A_k`` the coupling of length
    ``lam_k`` (:func:`coupling_stiffness_batch`) [mm/N].

    Each term is a part of the compliance that spreads along the face over its own length: the tooth
    (bending, shear, compression) over about half the tooth height, the gear body under it over the
    body's depth (docs/ltca.md section 2). A load uniform over the face deflects every slice by
    ``sum_k c_k f``, exactly, whatever the lengths.

    Parameters
    ----------
    z, widths : (B, M) arrays
        Slice positions and tributary widths [mm] (unused nodes: ``z`` NaN), as :func:`coupling_batch`.
    terms : sequence of (c, lam)
        ``c`` (B, M) compliance per unit face width of the term [mm^2/N] (> 0 at used nodes), ``lam``
        its coupling length [mm] (>= 0).

    Returns
    -------
    (B, M, M) array, zero rows/columns at unused nodes.
    """
    out = 0.0
    for c, lam in terms:
        d = np.sqrt(np.asarray(c, float))
        out = out + d[:, :, None] * coupling_batch(z, widths, float(lam)) * d[:, None, :]
    return out


def coupling_stiffness_batch(z: np.ndarray, widths: np.ndarray, lam: float) -> np.ndarray:
    """The tridiagonal ``A = diag(widths) + lam^2 K`` [mm] of :func:`coupling_batch` (whose inverse
    that is), (B, M, M); an unused node has a decoupled unit diagonal entry."""
    z = np.asarray(z, float)
    used = np.isfinite(z)
    B, M = z.shape
    A = np.zeros((B, M, M))
    i = np.arange(M)
    A[:, i, i] = np.where(used, widths, 1.0)  # an unused node: a decoupled unit entry (dropped below)
    if lam > 0 and M > 1:
        both = used[:, 1:] & used[:, :-1]
        h = np.where(both, np.diff(np.where(used, z, 0.0), axis=1), 1.0)
        k = np.where(both, lam**2 / h, 0.0)
        j = np.arange(M - 1)
        A[:, j, j] += k
        A[:, j + 1, j + 1] += k
        A[:, j, j + 1] -= k
        A[:, j + 1, j] -= k
    return A




def iso6336_stiffness(pair: GearPair) -> dict:
    """ISO 6336-1 (method B) single-pair and mesh stiffness of a spur or helical steel pair.

    ``q' = 0.04723 + 0.15551/z_n1 + 0.25791/z_n2 - 0.00635 x1 - 0.11654 x1/z_n1 - 0.00193 x2
    - 0.24188 x2/z_n2 + 0.00529 x1^2 + 0.00182 x2^2`` [mm um/N], ``c'_th = 1/q'``,
    ``c' = c'_th C_M C_R C_B cos(beta)`` (C_M = 0.8 solid disc, C_R = 1 solid gears,
    ``C_B = (1 + 0.5 (1.2 - h_fP/m_n)) (1 - 0.02 (20 deg - alpha_n))``),
    ``c_gamma_alpha = c' (0.75 eps_alpha + 0.25)`` [N/(mm um)] (for E = 206 GPa).
    """
    p, g = pair.pinion, pair.gear
    zn = [m.z / (math.cos(m.beta_b) ** 2 * math.cos(m.beta)) for m in (p, g)]
    x1, x2 = p.x, g.x
    q = (0.04723 + 0.15551 / zn[0] + 0.25791 / zn[1] - 0.00635 * x1 - 0.11654 * x1 / zn[0] - 0.00193 * x2
         - 0.24188 * x2 / zn[1] + 0.00529 * x1**2 + 0.00182 * x2**2)
    rack = p.rack
    C_B = (1 + 0.5 * (1.2 - rack.h_fP)) * (1 - 0.02 * (20.0 - math.degrees(rack.alpha_n)))
    c_th = 1.0 / q
    c_p = c_th * 0.8 * 1.0 * C_B * math.cos(p.beta)
    eps = pair.eps_alpha
    return {"q_prime": q, "c_th": c_th, "C_B": C_B, "c_prime": c_p, "eps_alpha": eps,
            "c_gamma_alpha": c_p * (0.75 * eps + 0.25)}



def body_coupling_length(tooth: ToothCompliance) -> float:
    """Coupling length of the gear body's term across the face [mm]: the body's depth under the
    tooth, ``r_f - r_int`` (docs/ltca.md section 2: the body term of Sainsot et al. spreads along the
    face over about that depth in the FE influence grids of benchmarks/ltca_face_coupling.py)."""
    return tooth.r_f - tooth.r_int
