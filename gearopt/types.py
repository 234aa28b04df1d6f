"""Type aliases of gearopt's annotations. Typing only: modules import them under
``if TYPE_CHECKING:`` (this module imports CasADi and NumPy)."""

from __future__ import annotations

from typing import Union

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

__all__ = ["ArrayLike", "Expr", "Param"]

#: A CasADi-generic value: a number, a NumPy array or a CasADi expression (SX, MX, DM). The functions
#: that take it return the same kind (NumPy in, NumPy out; CasADi in, CasADi out).
Expr = Union[float, np.ndarray, ca.SX, ca.MX, ca.DM]

#: A surface parameter vector ``p`` (:data:`gearopt.geometry.envelope.PARAMS` order), numeric or symbolic;
#: None for the tooth's own ``p0``.
Param = Union[ArrayLike, ca.SX, ca.MX, ca.DM, None]
