"""The spring-mass model: a :class:`~neurofuzzy.mesh.Mesh` plus its physical parameters.

A model is immutable; learners and tools return new models (``model.replace(...)``).

Regions
-------
A model may consist of several materials (an organ with a tumour): ``region_names`` names them
(``region_tissues`` gives the rule-base tissue of each, where known), ``spring_region`` and
``node_region`` say which region every spring and node belongs to. Tying never crosses a
region boundary (:meth:`SpringMassModel.tied`), so every region keeps its own learned values.

Parameter tying
---------------
``spring_tie`` assigns every spring to a tie group. Springs of one tie group are learned
together: the learners change their stiffness (and their viscosity) by one common factor, so
the ratios between tied springs stay as they start (all equal when they start equal, as in the
paper's homogeneous cube). ``tie="global"`` puts every spring into one group, ``"groups"`` uses
the mesh's spring groups (e.g. lattice edges and diagonals), ``"none"`` gives every spring its
own parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import InputError, closest_name
from ..forces.laws import LAWS, STIFFENING_CONSTANT, stiffens
from ..forces.relaxation import relaxation_fields
from ..mesh import Mesh
from .elements import VOLUMETRIC, element_values
from .values import PerSpring, Tie, describe, per_spring, tie_index, vector

__all__ = ["SpringMassModel", "VOLUMETRIC"]

@dataclass(frozen=True, eq=False)
class SpringMassModel:
    """Masses, spring constants and viscosities on a mesh (the paper's weights).

    Parameters
    ----------
    mesh : Mesh
        Nodes, springs, spring groups and fixed nodes.
    node_mass : (n_nodes,) float
        Mass ``m`` of every node (the paper's ``w_m = 1/m``).
    spring_stiffness : (n_springs,) float
        Spring constant ``s`` of every spring (force per unit stretch).
    spring_damping : (n_springs,) float
        Viscosity ``c`` of every spring (force per unit closing speed along the spring).
    spring_rest_length : (n_springs,) float, optional
        Rest length ``L0`` (default: the mesh's rest lengths).
    spring_tie : (n_springs,) int, optional
        Tie group of every spring (default: no tying, one group per spring).
    effects : tuple of Effect, optional
        Extra force terms the model carries (see :mod:`neurofuzzy.effects`).
    region_names : tuple of str, optional
        Names of the model's material regions (default one region, ``("object",)``).
    region_tissues : tuple of (str or None), optional
        The rule-base tissue of every region (default unknown).
    spring_region, node_region : (n_springs,), (n_nodes,) int, optional
        Region of every spring and node (default 0).
    element_youngs_modulus, element_poisson_ratio, element_viscosity : (n_tetrahedra,) float,
        optional
        Tetrahedral finite elements on ``mesh.tetrahedra`` (:mod:`neurofuzzy.forces.tetrahedra`):
        Young's modulus (Pa), Poisson's ratio in (0, 0.5) and viscosity (Pa·s) of every
        element; all three or none. Element models usually give their springs zero stiffness.
    element_tie : (n_tetrahedra,) int, optional
        Tie group of every element (default: one group per region); tied elements are
        learned as one E, ν and η (E and η keep their start ratios).
    element_region : (n_tetrahedra,) int, optional
        Region of every element (default 0).
    element_volumetric : {"nodal", "element"}
        How the elements' volumetric stress is formed
        (:mod:`neurofuzzy.forces.tetrahedra`): averaged over the tetrahedra around every
        node (the default; free of volumetric locking for nearly incompressible tissue) or
        per element (the textbook linear tetrahedron).
    element_law : str, int or (n_tetrahedra,) of them, optional
        Every element's material law (:mod:`neurofuzzy.forces.laws`):
        ``"st-venant-kirchhoff"`` (the default), ``"neo-hookean"`` or ``"yeoh"``, one for
        all elements or one per element; stored as law numbers.
    element_stiffening : float or (n_tetrahedra,) float, optional
        Yeoh's ``C₂₀/C₁₀`` (dimensionless, ≥ 0) of every element with the ``"yeoh"`` law:
        how much stiffer it grows with strain (0 is the uncoupled neo-Hookean solid); default
        :data:`~neurofuzzy.forces.laws.DEFAULT_STIFFENING`. Stored as (n_tetrahedra,); the
        other laws have no such constant and leave theirs unused (an element switched to Yeoh's
        law later starts from it).
    element_relaxation_moduli, element_relaxation_times : (K,) or (n_tetrahedra, K) float,
        optional
        Prony-series relaxation of the elements (:mod:`neurofuzzy.forces.relaxation`, 1–3
        terms): relative moduli ``gᵢ ≥ 0`` (of the long-term modulus E) and times
        ``τᵢ > 0`` (s), for all elements or per element; both or neither. Stored as
        (n_tetrahedra, K) arrays, K = 0 without relaxation.
    """

    mesh: Mesh
    node_mass: np.ndarray
    spring_stiffness: np.ndarray
    spring_damping: np.ndarray
    spring_rest_length: np.ndarray | None = None
    spring_tie: np.ndarray | None = None
    effects: tuple = field(default=())
    region_names: tuple = ("object",)
    region_tissues: tuple | None = None
    spring_region: np.ndarray | None = None
    node_region: np.ndarray | None = None
    element_youngs_modulus: np.ndarray | None = None
    element_poisson_ratio: np.ndarray | None = None
    element_viscosity: np.ndarray | None = None
    element_tie: np.ndarray | None = None
    element_region: np.ndarray | None = None
    element_volumetric: str = "nodal"
    element_law: np.ndarray | None = None
    element_relaxation_moduli: np.ndarray | None = None
    element_relaxation_times: np.ndarray | None = None
    element_stiffening: np.ndarray | None = None

    def __post_init__(self):
        mesh = self.mesh
        values = {
            "node_mass": vector(self.node_mass, mesh.n_nodes, "node_mass", "n_nodes"),
            "spring_stiffness": vector(self.spring_stiffness, mesh.n_springs,
                                        "spring_stiffness", "n_springs"),
            "spring_damping": vector(self.spring_damping, mesh.n_springs, "spring_damping",
                                      "n_springs"),
            "spring_rest_length": (mesh.rest_lengths if self.spring_rest_length is None else
                                   vector(self.spring_rest_length, mesh.n_springs,
                                           "spring_rest_length", "n_springs")),
        }
        for key in ("node_mass", "spring_rest_length"):
            if np.any(values[key] <= 0):
                raise InputError("must be positive", key=key)
        for key in ("spring_stiffness", "spring_damping"):
            if np.any(values[key] < 0):
                raise InputError("must not be negative", key=key)
        if self.spring_tie is None:
            tie = np.arange(mesh.n_springs, dtype=np.intp)
        else:
            tie = np.asarray(self.spring_tie)
            if tie.shape != (mesh.n_springs,) or not np.issubdtype(tie.dtype, np.integer):
                raise InputError(f"got {tie.dtype} of shape {tie.shape}; expected int of shape "
                                 f"({mesh.n_springs},)", key="spring_tie")
            _, tie = np.unique(tie, return_inverse=True)     # renumber to 0..n_ties-1
            tie = tie.astype(np.intp)
        values["spring_tie"] = tie
        names = tuple(str(name) for name in self.region_names)
        if not names or len(set(names)) != len(names):
            raise InputError(f"got {list(names)}; expected distinct names",
                             key="region_names")
        tissues = ((None,) * len(names) if self.region_tissues is None
                   else tuple(None if t is None else str(t) for t in self.region_tissues))
        if len(tissues) != len(names):
            raise InputError(f"got {len(tissues)} tissues for {len(names)} regions",
                             key="region_tissues")
        for key, n, size_name in (("spring_region", mesh.n_springs, "n_springs"),
                                  ("node_region", mesh.n_nodes, "n_nodes")):
            value = getattr(self, key)
            index = np.zeros(n, np.intp) if value is None else np.asarray(value)
            if index.shape != (n,) or not np.issubdtype(index.dtype, np.integer) or (
                    n and (index.min() < 0 or index.max() >= len(names))):
                raise InputError(f"expected ({size_name},) = ({n},) integers in "
                                 f"0..{len(names) - 1}, one region index each", key=key)
            values[key] = index.astype(np.intp)
        values.update(element_values(self))
        object.__setattr__(self, "region_names", names)
        object.__setattr__(self, "region_tissues", tissues)
        for key, value in values.items():
            if value is None:
                continue
            value = np.array(value)
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        object.__setattr__(self, "effects", tuple(self.effects))

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def uniform(cls, mesh: Mesh, *, stiffness: PerSpring, damping: PerSpring,
                node_mass: float | Sequence[float] | None = None,
                total_mass: float | None = None, tie: Tie = "none") -> SpringMassModel:
        """A model with the given constants, per spring group or for all springs.

        Parameters
        ----------
        mesh : Mesh
        stiffness, damping : float, (n_springs,) float or mapping group name -> float
            Spring constant and viscosity; a mapping gives one value per spring group,
            e.g. ``{"edge": 100.0, "diagonal": 50.0}``.
        node_mass : float or (n_nodes,) float, optional
            Mass of each node.
        total_mass : float, optional
            Instead of ``node_mass``: the object's mass, divided equally between the nodes
            (the paper's "predefined masses").
        tie : {"global", "groups", "none"}
            Parameter tying for learning.
        """
        if (node_mass is None) == (total_mass is None):
            raise InputError("give exactly one of node_mass and total_mass")
        masses = (np.full(mesh.n_nodes, total_mass / mesh.n_nodes) if total_mass is not None
                  else node_mass)
        return cls(mesh, node_mass=np.broadcast_to(np.asarray(masses, float), (mesh.n_nodes,)),
                   spring_stiffness=per_spring(mesh, stiffness, "stiffness"),
                   spring_damping=per_spring(mesh, damping, "damping"),
                   spring_tie=tie_index(mesh, tie))

    @classmethod
    def continuum(cls, mesh: Mesh, *, youngs_modulus, poisson_ratio, viscosity,
                  density, volumetric: str = "nodal", law="st-venant-kirchhoff",
                  relaxation=None, stiffening=None) -> SpringMassModel:
        """A tetrahedral finite-element model of ``mesh`` (which needs ``tetrahedra``).

        Parameters
        ----------
        youngs_modulus, poisson_ratio, viscosity : float or (n_tetrahedra,) float
            E (Pa), ν in (0, 0.5) and η (Pa·s) of every element.
        density : float or (n_tetrahedra,) float
            kg/m³; every node carries a quarter of the mass of each of its tetrahedra
            (lumped mass).
        volumetric : {"nodal", "element"}
            The elements' volumetric form (``element_volumetric``).
        law : str or (n_tetrahedra,), optional
            The elements' material law (``element_law``): ``"st-venant-kirchhoff"``,
            ``"neo-hookean"`` or ``"yeoh"``.
        relaxation : tuple of (g, τ) pairs, optional
            Prony terms for every element (``element_relaxation_moduli``,
            ``element_relaxation_times``), e.g. ``[(0.5, 0.05)]``: the standard linear solid
            whose long-term modulus is E and instantaneous one 1.5 E, relaxing in 50 ms.
        stiffening : float or (n_tetrahedra,), optional
            Yeoh's ``C₂₀/C₁₀`` of the Yeoh elements (``element_stiffening``).

        The springs of the mesh (its tetrahedron edges) get zero stiffness and damping.
        """
        from ..forces import tetrahedron_geometry

        geometry = tetrahedron_geometry(mesh)
        n = mesh.n_tetrahedra
        element_mass = np.broadcast_to(np.asarray(density, float), (n,)) * geometry.volume
        node_mass = np.bincount(geometry.nodes.ravel(), np.repeat(element_mass / 4, 4),
                                mesh.n_nodes)
        if np.any(node_mass <= 0):
            raise InputError("some nodes belong to no tetrahedron, so they carry no mass",
                             key="tetrahedra")
        return cls(mesh, node_mass=node_mass, spring_stiffness=0.0, spring_damping=0.0,
                   element_youngs_modulus=np.broadcast_to(youngs_modulus, (n,)),
                   element_poisson_ratio=np.broadcast_to(poisson_ratio, (n,)),
                   element_viscosity=np.broadcast_to(viscosity, (n,)),
                   element_volumetric=volumetric, element_law=law,
                   element_stiffening=stiffening, **relaxation_fields(relaxation))

    def replace(self, **changes) -> SpringMassModel:
        """A copy with some fields changed (``dataclasses.replace``)."""
        return replace(self, **changes)

    def tied(self, tie: Tie) -> SpringMassModel:
        """A copy with spring tying ``"global"``, ``"groups"`` or ``"none"`` within each
        region (tie groups never span two regions)."""
        combined = tie_index(self.mesh, tie) * len(self.region_names) + self.spring_region
        changes = {"spring_tie": combined}
        if self.has_elements:
            n = self.mesh.n_tetrahedra
            changes["element_tie"] = (np.arange(n, dtype=np.intp) if tie == "none"
                                      else self.element_region)
        return self.replace(**changes)

    @property
    def n_element_ties(self) -> int:
        return int(self.element_tie.max()) + 1 if self.has_elements else 0

    def region_springs(self, region: str) -> np.ndarray:
        """Indices of the springs of the region named ``region``."""
        return np.flatnonzero(self.spring_region == self._region_index(region))

    def region_elements(self, region: str) -> np.ndarray:
        """Indices of the tetrahedral elements of the region named ``region`` (empty for
        spring models)."""
        if not self.has_elements:
            return np.zeros(0, dtype=np.intp)
        return np.flatnonzero(self.element_region == self._region_index(region))

    def region_nodes(self, region: str) -> np.ndarray:
        """Indices of the nodes of the region named ``region``."""
        return np.flatnonzero(self.node_region == self._region_index(region))

    def _region_index(self, region: str) -> int:
        if region not in self.region_names:
            hint = closest_name(str(region), self.region_names)
            raise InputError(f"no region {region!r}" + (f"; did you mean {hint!r}?" if hint
                                                         else f"; the model has "
                                                         f"{list(self.region_names)}"),
                             key="region")
        return self.region_names.index(region)

    def with_effects(self, *effects) -> SpringMassModel:
        """A copy that carries ``effects`` in addition to those it has."""
        return self.replace(effects=self.effects + tuple(effects))

    # -- derived quantities ---------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        return self.mesh.n_nodes

    @property
    def n_springs(self) -> int:
        return self.mesh.n_springs

    @property
    def has_elements(self) -> bool:
        """True when the model carries tetrahedral finite elements."""
        return self.element_youngs_modulus is not None

    @property
    def n_relaxation_terms(self) -> int:
        """How many Prony terms the elements carry (0: no relaxation, or no elements)."""
        return self.element_relaxation_moduli.shape[1] if self.has_elements else 0

    @property
    def element_stiffens(self) -> np.ndarray:
        """(n_tetrahedra,) bool: the elements whose law has its own stiffening constant
        (``element_stiffening``, :data:`~neurofuzzy.forces.laws.STIFFENING_CONSTANT`; Yeoh's
        C₂₀/C₁₀); empty without elements."""
        return stiffens(self.element_law) if self.has_elements else np.zeros(0, bool)

    @property
    def force_terms(self) -> tuple:
        """Every force term of the model: its springs, its tetrahedral elements (if any),
        then its effects (each a :class:`~neurofuzzy.forces.ForceTerm`)."""
        from ..forces import SPRINGS, TETRAHEDRA

        return (SPRINGS, *((TETRAHEDRA,) if self.has_elements else ()), *self.effects)

    @property
    def node_inverse_mass(self) -> np.ndarray:
        """(n_nodes,) float: the paper's weight ``w_m = 1/m``, zero at fixed nodes (they never
        accelerate)."""
        weight = 1.0 / self.node_mass
        weight[self.mesh.fixed] = 0.0
        return weight

    @property
    def n_ties(self) -> int:
        return int(self.spring_tie.max()) + 1 if self.n_springs else 0

    def group_values(self, values: np.ndarray) -> dict[str, float]:
        """Mean of a per-spring array within each spring group, by group name."""
        groups = self.mesh.spring_group
        return {name: float(values[groups == g].mean())
                for g, name in enumerate(self.mesh.group_names) if np.any(groups == g)}

    def law_names(self) -> str:
        """The elements' material laws in words: one name, or each with its element count."""
        numbers, counts = np.unique(self.element_law, return_counts=True)
        if len(numbers) == 1:
            return LAWS[int(numbers[0])]
        return ", ".join(f"{LAWS[int(n)]} ({int(c)} elements)" for n, c in zip(numbers, counts))

    def summary(self) -> str:
        """Short human-readable description of the parameters."""
        springs = bool(np.any(self.spring_stiffness != 0) or np.any(self.spring_damping != 0))
        if self.has_elements:
            lines = [f"SpringMassModel: {self.n_nodes} nodes ({len(self.mesh.fixed)} fixed), "
                     f"{self.mesh.n_tetrahedra} tetrahedral elements, {self.n_element_ties} "
                     f"tie group(s)" + (f", {self.n_springs} springs" if springs else "")]
        else:
            lines = [f"SpringMassModel: {self.n_nodes} nodes ({len(self.mesh.fixed)} fixed), "
                     f"{self.n_springs} springs, {self.n_ties} tie group(s)"]
        lines.append(f"  node mass: {describe(self.node_mass)}")
        if self.has_elements:
            lines.append(f"  elements: Young's modulus {describe(self.element_youngs_modulus)}"
                         f" Pa, Poisson's ratio {describe(self.element_poisson_ratio)}, "
                         f"viscosity {describe(self.element_viscosity)} Pa s")
            lines.append(f"  material law: {self.law_names()}")
            for law, name in STIFFENING_CONSTANT.items():
                own = self.element_law == law
                if own.any():
                    lines.append(f"  {LAWS[law].capitalize()} stiffening {name}: "
                                 f"{describe(self.element_stiffening[own])}")
            for k in range(self.n_relaxation_terms):
                lines.append(f"  relaxation term {k + 1}: relative modulus "
                             f"{describe(self.element_relaxation_moduli[:, k])}, time "
                             f"{describe(self.element_relaxation_times[:, k])} s")
        for g, name in enumerate(self.mesh.group_names if springs or not self.has_elements
                                 else ()):
            sel = self.mesh.spring_group == g
            lines.append(f"  {name} ({int(sel.sum())} springs): stiffness "
                         f"{describe(self.spring_stiffness[sel])}, damping "
                         f"{describe(self.spring_damping[sel])}")
        if len(self.region_names) > 1 or self.region_tissues[0] is not None:
            for index, (name, tissue) in enumerate(zip(self.region_names, self.region_tissues)):
                parts = (f"{int(np.sum(self.element_region == index))} elements"
                         if self.has_elements else
                         f"{int(np.sum(self.spring_region == index))} springs")
                lines.append(f"  region {name}{f' ({tissue})' if tissue and tissue != name else ''}"
                             f": {int(np.sum(self.node_region == index))} nodes, {parts}")
        lines += [f"  effect: {effect}" for effect in self.effects]
        return "\n".join(lines)

