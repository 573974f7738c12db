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
"""

from __future__ import annotations

import numpy as np

__all__ = ["hertz_force", "bonded_layer_force", "quarter_block"]


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
