"""The checked arguments of a tooth contact sweep: what :meth:`gearopt.meshing.tca.TCA.sweep` and
``EdgeContact.sweep`` accept (pinion angles, both members' parameter vectors, a misalignment, tooth
pairs, delta, anchor and section), validated and normalised into :class:`SweepArgs`, and the error of a
sweep that found no contact anywhere."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError, ConvergenceError, OptionError, out_of_range, shorten
from ..geometry.generation import GeneratedTooth
from .misalignment import Misalignment

if TYPE_CHECKING:
    from .tca import TCA


def describe(v: object) -> str:
    """``type repr`` of a bad argument, shortened, for the error messages."""
    return f"{type(v).__name__} {shorten(repr(v))}"



class SweepArgs(NamedTuple):
    """The checked arguments of a sweep (:func:`check_sweep_args`)."""

    phi1: np.ndarray  #: (N,) pinion angles [rad]
    p1: np.ndarray  #: the pinion's parameter vector (its ``param_names`` entries)
    p2: np.ndarray  #: the gear's
    mis: Misalignment
    pairs: tuple[int, ...]  #: tooth pairs (pinion tooth numbers)



def default_vector(tca: TCA, name: str, tooth: GeneratedTooth) -> np.ndarray:
    """``tooth.p0`` (a new array), kept per TCA under ``name`` ("p1" or "p2"): the teeth of a TCA are
    fixed when it is built, and assembling p0 from the gear's data costs a few microseconds a sweep."""
    kept = getattr(tca, "_defaults", None)
    if kept is None:
        return np.asarray(tooth.p0, float)
    if name not in kept:
        kept[name] = np.asarray(tooth.p0, float)
    return kept[name].copy()



def check_sweep_args(tca: TCA, phi1: npt.ArrayLike, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None,
                     mis: Misalignment | None = None, pairs: Sequence[int] = (-1, 0, 1), delta: float | None = None,
                     anchor: float = 0.0, z_section: float | None = 0.0) -> SweepArgs:
    """Validate and normalise the arguments of :meth:`TCA.sweep` / ``EdgeContact.sweep``.

    Returns :class:`SweepArgs` ``(phi1 (N,), p1, p2, mis, pairs)`` (p1, p2: each member's ``param_names`` entries); raises :class:`~gearopt.errors.ArgumentError`
    (wrong type, shape, empty, non-finite) or :class:`~gearopt.errors.GeometryError` (a misalignment
    that jams or separates the teeth, faces that do not overlap, a section off the face), naming
    the argument and its valid range.
    """
    pair = tca.pair
    g1 = pair.pinion
    try:
        arr = np.asarray(phi1)
        if arr.dtype.kind in "USb":  # "0.1" would convert: the API takes numbers in rad
            raise TypeError
        arr = arr.astype(float, copy=False)
    except (TypeError, ValueError):
        raise ArgumentError(f"phi1 = {describe(phi1)}: expected a sequence of pinion angles [rad] (numbers).",
                            param="phi1", value=phi1, valid="a sequence of pinion angles [rad] (numbers)") from None
    if arr.ndim > 1:
        raise ArgumentError(f"phi1: expected a 1-D sequence of pinion angles [rad], got shape {arr.shape}.",
                            param="phi1", valid="a 1-D sequence of pinion angles [rad]")
    arr = np.atleast_1d(arr)
    if arr.size == 0:
        raise ArgumentError("phi1 is empty: a sweep needs at least one pinion angle [rad] (one mesh cycle is "
                            f"2 pi / z1 = {2 * math.pi / g1.z:.6g} rad).",
                            param="phi1", valid="at least one pinion angle [rad]")
    fin = np.isfinite(arr)
    if not fin.all():
        bad = np.flatnonzero(~fin)
        raise ArgumentError(f"phi1[{bad[0]}] = {arr[bad[0]]}: every pinion angle must be a finite number [rad] "
                            f"({bad.size} of {arr.size} are not).",
                            param=f"phi1[{bad[0]}]", value=float(arr[bad[0]]), valid="a finite number [rad]")
    vecs = []
    for name, p, tooth in (("p1", p1, tca.pinion), ("p2", p2, tca.gear)):
        if p is None:
            vecs.append(default_vector(tca, name, tooth))
            continue
        names = tooth.param_names  # PARAMS, then the theta of any flank modification
        try:
            v = np.asarray(p, dtype=float)
        except (TypeError, ValueError):
            raise ArgumentError(f"{name} = {describe(p)}: expected {len(names)} numbers {names}.",
                                param=name, value=p, valid=f"{len(names)} numbers {names}") from None
        if v.shape != (len(names),):
            raise ArgumentError(f"{name}: expected a vector of {len(names)} numbers {names} (x, a_c [1/mm], u_0 [mm], "
                                f"a_pl [1/mm], then any modification parameters), got shape {v.shape}.",
                                param=name, valid=f"a vector of {len(names)} numbers {names}")
        if not np.all(np.isfinite(v)):
            bad = [n_ for n_, x_ in zip(names, v) if not math.isfinite(x_)]
            raise ArgumentError(f"{name} = {v.tolist()}: every entry of {names} must be finite ({bad} are not).",
                                param=name, value=v.tolist(), valid="finite entries")
        vecs.append(v)
    if mis is None:
        mis = Misalignment()
    elif not isinstance(mis, Misalignment):
        hint = " Use Misalignment(**d) (angles in rad)." if isinstance(mis, dict) else ""
        kinds = ", ".join(f"{k} [{'rad' if Misalignment.meta(k)['unit'] == 'angle' else 'mm'}]"
                          for k in Misalignment.names())
        raise ArgumentError(f"mis = {describe(mis)}: expected a gearopt.meshing.tca.Misalignment ({kinds}).{hint}",
                            param="mis", value=mis, valid="a gearopt.meshing.tca.Misalignment")
    checked = getattr(tca, "_checked_mis", None)  # misalignments this TCA's pair accepted (frozen: same answer)
    if checked is None or mis not in checked:
        mis.check(pair, "mis")
        if checked is not None:
            if len(checked) >= 256:
                checked.clear()
            checked.add(mis)
    try:
        seq = list(pairs)
    except TypeError:
        raise ArgumentError(f"pairs = {describe(pairs)}: expected a sequence of tooth-pair indices (integers), "
                            "e.g. (-1, 0, 1).",
                            param="pairs", value=pairs, valid="a sequence of tooth-pair indices (integers)") from None
    if not seq:
        raise ArgumentError("pairs is empty: give at least one tooth-pair index, e.g. (0,) or (-1, 0, 1).",
                            param="pairs", valid="at least one tooth-pair index")
    out = []
    for k in seq:
        if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)):
            raise ArgumentError(f"pairs contains {describe(k)}: tooth-pair indices are integers (pinion tooth k, "
                                f"-{g1.z} < k < {g1.z}).",
                                param="pairs", value=k, valid=f"-{g1.z} < k < {g1.z}")
        if abs(int(k)) >= g1.z:
            raise ArgumentError(f"pairs contains {int(k)}; valid: -{g1.z} < k < {g1.z} (pinion teeth from tooth 0).",
                                param="pairs", value=int(k), valid=f"-{g1.z} < k < {g1.z}")
        out.append(int(k))
    if len(set(out)) != len(out):
        raise ArgumentError(f"pairs = {tuple(out)}: every tooth pair may appear once.",
                            param="pairs", value=tuple(out), valid="every tooth pair may appear once")
    for name, v in (("delta", delta), ("anchor", anchor), ("z_section", z_section)):
        if v is None:
            continue
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not math.isfinite(v):
            raise ArgumentError(f"{name} = {describe(v)}: expected a finite number.",
                                param=name, value=v, valid="a finite number", detail=": expected a finite number.")
    if delta is not None and not 0 < delta <= 0.1 * g1.m_n:
        raise out_of_range("delta", delta, f"0 < delta <= 0.1 m_n = {0.1 * g1.m_n:.4g} mm (elastic approach for the "
                           "contact ellipse, microns)", cls=OptionError)
    if tca.contact_type == "line" and z_section is not None and abs(z_section) > g1.b / 2:
        raise out_of_range("z_section", z_section, f"|z_section| <= b1 / 2 = {g1.b / 2:.6g} mm (a section of the "
                           "pinion face)", cls=OptionError)
    return SweepArgs(phi1=arr, p1=vecs[0], p2=vecs[1], mis=mis, pairs=tuple(out))



def no_contact(where: str, phi1: np.ndarray, pairs: Sequence[int], z1: int) -> ConvergenceError:
    """The error for a sweep that found no contact at any position (never an all-NaN result)."""
    return ConvergenceError(
        f"{where}: no contact at any of the {phi1.size} positions phi1 = {phi1.min():.6g} .. "
        f"{phi1.max():.6g} rad (pairs {tuple(pairs)}). The angles may lie outside the meshing cycle (pair 0 meshes "
        f"around phi1 = 0; one cycle is 2 pi / z1 = {2 * math.pi / z1:.6g} rad; angles are in rad), or the flanks do "
        "not meet under this misalignment.")
