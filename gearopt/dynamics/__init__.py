"""Gear dynamics driven by the loaded TCA (docs/dynamics.md): a lumped-parameter torsional model of
a gear pair along the line of action, its periodic steady state over speed (CasADi shooting), the
dynamic factor, mesh-order response, contact loss and Floquet stability."""

from .model import (DriveTrain, GearDynamics, MeshExcitation, PeriodicSolution, SpeedSweep, sdof_response,
                    solid_disc_inertia)

__all__ = ["DriveTrain", "GearDynamics", "MeshExcitation", "PeriodicSolution", "SpeedSweep", "sdof_response",
           "solid_disc_inertia"]
