"""The compiled path of :meth:`neurofuzzy.learn.Sensitivity.run`: the model, its parameter
directions, the experiment's loads, window starts and observation operator laid out for
:func:`neurofuzzy._numba_sensitivity.forward` (one call per experiment, no Python per time
step). Used when numba is installed and the model carries only springs and tetrahedral
elements with fixed masses; everything else takes the numpy reference path."""

from __future__ import annotations

import numpy as np

from ..forces import TETRAHEDRA
from ..forces.tetra_geometry import Materials, lame_factors
from ..simulation import numba_available
from ._parameters import ELEMENT_BLOCKS, element_directions

__all__ = ["compiled_possible", "CompiledModel"]


def compiled_possible(parameters, model) -> bool:
    """True when the compiled kernel computes exactly what the numpy path computes."""
    return (numba_available() and not model.effects and not parameters.effects
            and not parameters.learn_masses)


class CompiledModel:
    """Kernel arrays of one model (one parameter vector) and its parameter directions."""

    def __init__(self, parameters, model):
        self.model = model
        n_params = parameters.size
        blocks = parameters.blocks
        springs = (np.arange(model.n_springs) if parameters.learn_springs else
                   np.flatnonzero((model.spring_stiffness != 0) | (model.spring_damping != 0)))
        tie = parameters.tied.tie[springs]
        no_column = np.full(len(springs), -1, np.intp)
        self.springs = (
            np.ascontiguousarray(model.mesh.springs[springs, 0]),
            np.ascontiguousarray(model.mesh.springs[springs, 1]),
            model.spring_stiffness[springs].copy(), model.spring_damping[springs].copy(),
            model.spring_rest_length[springs].copy(),
            (blocks["log_stiffness"].start + tie).astype(np.intp)
            if parameters.learn_springs else no_column,
            (blocks["log_damping"].start + tie).astype(np.intp)
            if parameters.learn_springs else no_column)
        self.elements = self._elements(parameters, model, n_params)
        self.weight = model.node_inverse_mass
        self.n_params = n_params

    @staticmethod
    def _elements(parameters, model, n_params):
        n_nodes = model.n_nodes
        if not model.has_elements:
            empty, none = np.zeros(0), np.zeros(0, np.intp)
            return (np.zeros((0, 4), np.intp), np.zeros((0, 3, 3)), empty, empty, empty, empty,
                    False, empty, empty, empty, none, none, none, empty, empty,
                    np.zeros((0, n_params)), np.zeros((0, n_params)))
        materials = Materials.of(model)
        geometry = materials.geometry
        nu = model.element_poisson_ratio
        a, b, da, db = lame_factors(nu)
        logistic = nu * (1.0 - 2.0 * nu)                     # dν/d logit (2ν)
        first = parameters.blocks[ELEMENT_BLOCKS[0]].start
        ties, tie = model.n_element_ties, model.element_tie
        d_node_lam = np.zeros((n_nodes, n_params))
        d_node_lam_rate = np.zeros((n_nodes, n_params))
        if materials.nodal:
            d_lam, d_lam_rate = TETRAHEDRA.lame_changes(model, element_directions(model))
            span = slice(first, first + 3 * ties)
            d_node_lam[:, span] = (geometry.average @ d_lam).toarray()
            d_node_lam_rate[:, span] = (geometry.average @ d_lam_rate).toarray()
            node_values = (geometry.node_volume, materials.node_lam, materials.node_lam_rate)
        else:
            node_values = (np.zeros(n_nodes),) * 3
        return (np.array(geometry.nodes, np.intp, order="C"),
                np.ascontiguousarray(geometry.inverse_rest), geometry.volume, materials.lam,
                0.5 * materials.shear, model.element_viscosity / model.element_youngs_modulus,
                materials.nodal, *(np.ascontiguousarray(v, float) for v in node_values),
                (first + tie).astype(np.intp), (first + ties + tie).astype(np.intp),
                (first + 2 * ties + tie).astype(np.intp), da / a * logistic,
                db / b * logistic, d_node_lam, d_node_lam_rate)

    def run(self, experiment, states, *, substeps: int, scale: float, tangents: bool):
        """``(positions, jacobian)`` of one experiment; ``states`` maps every window start
        frame to its ``(p, v)``."""
        from .._numba_sensitivity import forward

        n_frames, n_nodes = experiment.n_frames, self.model.n_nodes
        start_index = np.full(n_frames, -1, np.intp)
        frames = sorted(states)
        start_index[frames] = np.arange(len(frames))
        start_p = np.stack([states[t][0] for t in frames]).astype(float)
        start_v = np.stack([states[t][1] for t in frames]).astype(float)
        observation = experiment.observation
        operator = observation.operator.tocsr()
        positions = np.empty((n_frames, n_nodes, 3))
        jacobian = (np.empty((n_frames - 1, observation.n_rows, 3, self.n_params)) if tangents
                    else np.zeros((0, 0, 3, 0)))
        # writable C-ordered copies: numba compiles one signature per array layout
        loads = np.array(experiment.forces_per_frame(), dtype=float, order="C")
        h = experiment.dt / substeps
        with np.errstate(over="ignore", invalid="ignore"):
            forward(start_p[0].copy(), start_v[0].copy(), *self.springs, *self.elements,
                    self.weight, loads, h, n_frames, int(substeps), self.n_params,
                    start_index, start_p, start_v, operator.indptr.astype(np.intp),
                    operator.indices.astype(np.intp), operator.data.astype(float),
                    np.array(observation.seen, dtype=bool, order="C"), float(scale),
                    bool(tangents),
                    positions, jacobian)
        return positions, (jacobian if tangents else None)
