"""Indentation by a rigid sphere: the closed forms our contact is checked against, and the
quarter block the checks run on.

- :func:`hertz_force`: Hertz's sphere on an elastic half-space,
  ``F = 4/3 E/(1-ν²) √R δ^1.5``.
- :func:`bonded_layer_force`: the same on a layer of thickness ``h`` bonded to a rigid base,
  Dimitriadis et al. (Biophys. J. 82, 2798-2810, 2002): Hertz's force times a series in
  ``χ = √(Rδ)/h`` with their ν-dependent coefficients ``α₀``, ``β₀`` (fitted for ν 0.3 to
  0.5), its ``χ⁴`` term signed so that at ν = 0.5 the series is their incompressible one,
  ``1 + 1.133 χ + 1.283 χ² + 0.769 χ³ + 0.0975 χ⁴`` (``tests/test_contact.py``).
- :func:`quarter_block`: a quarter of a block pressed at its top middle, with symmetry
  planes, its cells shrinking geometrically toward the contact (what
  ``benchmarks/indentation.py`` and ``tests/test_contact.py`` measure on).
- :data:`DEEP`: the deep-indentation experiment that sfepy recorded
  (``tests/data/indentation_nu0.45.npz``, :mod:`.nonlinear.indentation`; at ν 0.49 and
  0.499 in its mixed form, ``indentation_nu0.49.npz`` and ``indentation_nu0.499.npz``) and
  ``benchmarks/indentation_deep.py`` fits, with :meth:`DeepIndentation.lab_data` to turn
  the recording into what a lab has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["hertz_force", "bonded_layer_force", "quarter_block", "DeepIndentation", "DEEP"]


def hertz_force(youngs_modulus, poisson_ratio, radius, depth):
    """Hertz's force (N) of a rigid sphere of ``radius`` pressed ``depth`` (m) into an
    elastic half-space."""
    return (4 / 3 * youngs_modulus / (1 - poisson_ratio**2) * np.sqrt(radius)
            * np.asarray(depth, float) ** 1.5)


def bonded_layer_force(youngs_modulus, poisson_ratio, radius, depth, thickness):
    """The sphere's force (N) on a layer of ``thickness`` bonded to a rigid base
    (Dimitriadis et al. 2002, eq. 12; module docstring)."""
    nu = poisson_ratio
    chi = np.sqrt(radius * np.asarray(depth, float)) / thickness
    a0 = -(1.2876 - 1.4678 * nu + 1.3442 * nu**2) / (1 - nu)
    b0 = (0.6387 - 1.0277 * nu + 1.5164 * nu**2) / (1 - nu)
    series = (1 - 2 * a0 / np.pi * chi + 4 * a0**2 / np.pi**2 * chi**2
              - 8 / np.pi**3 * (a0**3 + 4 * np.pi**2 * b0 / 15) * chi**3
              - 16 * a0 / np.pi**4 * (a0**3 + 3 * np.pi**2 * b0 / 5) * chi**4)
    return hertz_force(youngs_modulus, nu, radius, depth) * series


def quarter_block(cells: int, *, half_width: float, height: float, stretch: float = 4.5,
                  youngs_modulus: float = 6000.0, poisson_ratio: float = 0.45,
                  law: str = "st-venant-kirchhoff"):
    """``(model, planes)``: the quarter ``[0, half_width]² × [0, height]`` of a block, ``cells``
    a side, the cells growing by ``e^(stretch / cells)`` from the top corner ``x = y = 0``
    (where a tool presses), the bottom fixed; ``planes``: ``(nodes, component)`` of the
    symmetry planes ``x = 0`` and ``y = 0``, to be held at rest in that component alone (so
    they slide; :class:`~neurofuzzy.simulation.static.Driven`)."""
    from ..mesh import from_tetra, kuhn_block
    from ..model import Model

    points, tetrahedra = kuhn_block((cells,) * 3, 1.0)
    xi = points / cells

    def grow(t, length):
        return length * np.expm1(stretch * t) / np.expm1(stretch)

    points = np.column_stack([grow(xi[:, 0], half_width), grow(xi[:, 1], half_width),
                              height - grow(1 - xi[:, 2], height)])
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-12 * height)
    model = Model.continuum(mesh, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                            viscosity=1.0, density=1000.0, law=law)
    free = np.ones(mesh.n_nodes, bool)
    free[mesh.fixed] = False
    planes = [(np.flatnonzero((points[:, k] < 1e-12 * half_width) & free), "xy"[k])
              for k in (0, 1)]
    return model, planes


@dataclass(frozen=True)
class DeepIndentation:
    """A 4 × 4 × 2 cm block of neo-Hookean tissue (E 6 kPa) bonded to a rigid base, a sphere
    of radius 1 cm pressed 1 to 4 mm (5 to 20 % of the height) into the middle of its top; a
    load cell with 1 % noise and 20 markers on the top surface with 20 µm noise. Modelled as
    the quarter ``[0, half_width]² × [0, height]`` (:func:`quarter_block` with ``stretch``)."""

    youngs_modulus: float = 6000.0
    height: float = 0.02
    half_width: float = 0.02
    radius: float = 0.01
    depths: tuple = (1e-3, 2e-3, 3e-3, 4e-3)
    stretch: float = 2.0
    force_noise: float = 0.01
    marker_noise: float = 20e-6

    def centres(self) -> np.ndarray:
        """(n_steps + 1, 3): the sphere's centre touching the top, then at each depth."""
        top = self.height + self.radius
        return np.array([[0.0, 0.0, top - d] for d in (0.0, *self.depths)])

    def markers(self) -> np.ndarray:
        """(20, 3): rest points on the quarter's top face, 5 radii (3 to 17 mm) by 4
        angles."""
        radii = np.array([0.15, 0.325, 0.5, 0.675, 0.85]) * self.half_width
        angles = np.radians([10.0, 35.0, 55.0, 80.0])
        r, a = np.meshgrid(radii, angles, indexing="ij")
        return np.column_stack([(r * np.cos(a)).ravel(), (r * np.sin(a)).ravel(),
                                np.full(r.size, self.height)])

    def quarter(self, cells: int, poisson_ratio: float = 0.45, **keywords):
        """:func:`quarter_block` of this experiment, ``cells`` a side."""
        return quarter_block(cells, half_width=self.half_width, height=self.height,
                             stretch=self.stretch, youngs_modulus=self.youngs_modulus,
                             poisson_ratio=poisson_ratio, **keywords)

    def lab_data(self, recorded, model, planes, *, with_markers: bool = True, seed: int = 0):
        """The recording as a lab has it, on ``model`` (a quarter of ``planes``): the
        quarter's share of the force with :attr:`force_noise`, every scan of the markers (the
        rest one too) with :attr:`marker_noise`, embedded where the first scan saw them."""
        from ..load_steps import DrivenPath, LoadSteps, ToolPath
        from ..observation import EmbeddedMarkers, embed_points
        from ..simulation.contact import Sphere

        rng = np.random.default_rng(seed)
        force = np.asarray(recorded["force"], float) / 4
        reaction = force + self.force_noise * np.abs(force[:, 2:]) * rng.normal(
            size=force.shape)
        tool = ToolPath(Sphere(float(recorded["radius"])), recorded["centres"])
        paths = tuple(DrivenPath(nodes, np.zeros((len(force), 3)), component,
                                 f"plane {component}") for nodes, component in planes)
        embedded = None
        if with_markers:
            rest = recorded["markers"]
            scans = np.concatenate([rest[None], rest + recorded["displacements"]])
            scans = scans + rng.normal(scale=self.marker_noise, size=scans.shape)
            nodes, weights, _ = embed_points(model.mesh, scans[0])
            embedded = EmbeddedMarkers(nodes, weights, scans)
        return LoadSteps(model.mesh, paths, embedded, reaction, tool=tool)


#: the experiment of ``tests/data/indentation_nu<ν>.npz`` (ν 0.45, 0.49, 0.499)
DEEP = DeepIndentation()
