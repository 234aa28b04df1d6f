"""Mirror-image cases of a drive symmetric about its mid-face (docs/loaded_synthesis.md section 5).

Under the mirror z -> -z each misalignment kind keeps or changes its sign; that sign is declared
with the kind itself (the ``mirror`` entry of each :class:`~gearopt.meshing.misalignment.Misalignment`
field's metadata, :meth:`Misalignment.mirror_sign`), and every field is read here: a kind without a
declared sign disables the mirror reduction instead of being skipped."""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING

import numpy as np

from ...errors import ArgumentError
from ...meshing.misalignment import Misalignment

if TYPE_CHECKING:
    from typing import Self


def mirror_signs(cls: type[Misalignment] = Misalignment) -> dict[str, int]:
    """``{kind: sign}`` of every field of the misalignment class ``cls`` (its declared
    :meth:`~gearopt.meshing.misalignment.Misalignment.mirror_sign`, None where a field declares none)."""
    return {k: cls.mirror_sign(k) for k in cls.names()}


#: sign of each misalignment kind under the mirror z -> -z, as declared by Misalignment's fields
#: (for reference: the functions below read the fields at every call)
MIRROR_SIGN = mirror_signs()


def mirror_image(mis: Misalignment) -> Misalignment:
    """The misalignment mirrored in z (each kind of its class times its declared mirror sign);
    :class:`ArgumentError` naming the kind when one declares no mirror sign."""
    cls = type(mis)
    signs = mirror_signs(cls)
    for k, s in signs.items():
        if s is None:
            raise ArgumentError(f"misalignment kind {k!r}: its sign under the mirror z -> -z is not declared "
                                f"(the 'mirror' entry of the field's metadata, {cls.__name__}.mirror_sign).",
                                param=k, value=k, valid="a field declaring mirror = +1 or -1")
    return cls(**{k: signs[k] * getattr(mis, k) for k in signs})


class MirrorReduction:
    """Mirror-image cases of the duty cycle: their classes, the reduced optimiser of one case per class, and
    the duty cycle shifted by a misalignment."""

    def mirror_classes(self) -> list[list[int]] | None:
        """Cases that are mirror images of each other (docs/loaded_synthesis.md section 5): lists of
        case indices whose loaded TCA is the same for every design the optimiser may choose, or None
        when the drive is not mirror-symmetric about its mid-face. A spur pair whose flanks are
        symmetric in z (no helix slope, bias, off-centre lead crowning, unequal end reliefs or measured
        deviations; none of these free) meshes under a misalignment as under its mirror image
        (:func:`mirror_image`: ``(dE, crossing, intersecting, axial)`` as ``(dE, -crossing,
        -intersecting, -axial)``) mirrored in z. Every kind is read from the cases' class (the fields
        of ``Misalignment``, each with its declared mirror sign); one without a declared sign, or cases
        of different classes, leave every case on its own (None)."""
        asym = ("f_H_beta", "S_alpha", "z_Cb", "C_beta_I", "C_beta_II")
        if any(n.split(".", 1)[1] in asym for n in self.free):
            return None
        for g in (self.pair.pinion, self.pair.gear):
            if g.beta != 0.0:
                return None
            mg = g.modifications
            if mg is not None and (mg.f_H_beta or mg.S_alpha or mg.z_Cb or mg.measured or mg.C_beta_I != mg.C_beta_II
                                   or mg.b_I != mg.b_II):
                return None
        types = {type(m) for m in self.cases}
        if len(types) != 1:
            return None
        signs = mirror_signs(types.pop())
        if any(s is None for s in signs.values()):
            return None  # a kind whose mirror image is not known: no case is taken for another's
        kinds = tuple(signs)
        key = lambda m: tuple(round(float(getattr(m, k)), 15) for k in kinds)  # noqa: E731
        keys = [key(m) for m in self.cases]
        classes, seen = [], set()
        for c, m in enumerate(self.cases):
            if c in seen:
                continue
            mk = key(mirror_image(m))
            twin = [j for j in range(c + 1, len(keys)) if keys[j] == mk and j not in seen and keys[j] != keys[c]]
            cls = [c] + twin[:1]
            seen.update(cls)
            classes.append(cls)
        return classes if any(len(k) > 1 for k in classes) else None

    def shifted(self, offset: Misalignment) -> Self:
        """A copy of this optimiser with ``offset`` added to every case (each kind of ``Misalignment``);
        the duty cycle :meth:`sensitivities` differentiates in (e.g. for finite differences of
        re-solved optima, ``benchmarks/loaded_sensitivity_fd.py``)."""
        if not isinstance(offset, Misalignment):
            raise ArgumentError(f"offset = {offset!r:.60}: expected a gearopt Misalignment.", param="offset",
                                value=offset, valid="a Misalignment")
        out = copy.copy(self)
        out.cases = tuple(Misalignment(**{k: getattr(c, k) + getattr(offset, k) for k in Misalignment.names()})
                          for c in self.cases)
        out.phi1 = self.phi1.copy()
        return out

    def _reduced(self):
        """The optimiser of one case per mirror class (:meth:`mirror_classes`), its weights the sums of
        the class's and its penalty counting each class as often as it has members (the same merit,
        objective and constraints as the full duty cycle at every symmetric design); self when no
        case has a mirror image."""
        classes = self.mirror_classes()
        if classes is None:
            return self
        red = copy.copy(self)
        red.cases = tuple(self.cases[k[0]] for k in classes)
        red.weights = np.stack([self.weights[:, k].sum(axis=1) for k in classes], axis=1)
        red._mult = np.tile(np.array([len(k) for k in classes], float), (self.torques.size, 1))
        red._w_mean = self._w_mean
        return red
