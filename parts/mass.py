"""Mass, centre of mass and inertia of a part from its exact mesh and its material (or given
mass). Split out of :mod:`asmplan.parts.geometry`, which re-exports it."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..knowledge.arrays import readonly_array
from ..knowledge.model import Part


@dataclass(frozen=True, eq=False)
class MassProperties:
    """Mass, centre of mass and inertia of a part (SI, part frame).

    Parameters
    ----------
    mass_kg : float
    com_m : (3,) float array, part frame.
    inertia_kgm2 : (3, 3) float array about the centre of mass, part axes.
    volume_m3 : float
    density_kg_m3 : float
        The material's, or mass / volume when the mass was given.
    source : str
        "material" or "given mass".
    """

    mass_kg: float
    com_m: np.ndarray
    inertia_kgm2: np.ndarray
    volume_m3: float
    density_kg_m3: float
    source: str

    def __post_init__(self) -> None:
        if not (math.isfinite(self.mass_kg) and self.mass_kg > 0):
            raise ValueError(f"MassProperties.mass_kg: expected > 0, found {self.mass_kg!r}")
        for name, shape in (("com_m", (3,)), ("inertia_kgm2", (3, 3))):
            object.__setattr__(self, name,
                               readonly_array(getattr(self, name), shape, f"MassProperties.{name}"))


def mass_properties(part: Part, mesh) -> MassProperties:
    """Mass properties of ``part`` from its exact watertight ``mesh`` (a
    :class:`~asmplan.parts.mesh.TriangleMesh` or a trimesh).

    The density is the material's unless the part gives its mass, in which case the mass is
    kept and the density follows from the volume.
    """
    from .geometry import GeometryError  # geometry re-exports this module

    volume = float(mesh.volume)
    if not (volume > 0):
        raise GeometryError(part.name, f"expected a positive volume, found {volume:.3g} m^3")
    if part.mass_kg is not None:
        density, source = part.mass_kg / volume, "given mass"
    elif part.material is not None:
        density, source = part.material.density_kg_m3, "material"
    else:  # the loader requires one of them
        raise GeometryError(part.name, 'expected "material" or "mass", found neither')
    com = np.asarray(mesh.center_mass, dtype=float)
    # moment_inertia is about the centre of mass for the mesh's density (1 unless a trimesh
    # was given another)
    mesh_density = float(getattr(mesh, "density", 1.0))
    inertia = np.asarray(mesh.moment_inertia, dtype=float) * density / max(mesh_density, 1e-300)
    return MassProperties(volume * density, com, inertia, volume, density, source)
