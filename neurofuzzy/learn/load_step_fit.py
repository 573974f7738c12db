"""Young's modulus and Poisson's ratio from scans at load steps and, where a load cell was
used, its force: :func:`fit_load_steps`.

Each load step is a static equilibrium (:func:`neurofuzzy.simulation.equilibrium`) with the
driven sets where the stage put them. The fit is a Levenberg–Marquardt least squares over the
markers of every step (and the load cell's force at every step), each weighted by its own
noise, with exact sensitivities of the equilibrium: at a solution ``F_f(p; θ) = 0`` on the
free degrees of freedom, so ``∂p_f/∂θ = K_ff⁻¹ ∂F_f/∂θ`` (one solve per parameter with the
equilibrium's stiffness), and the elements' force is exactly linear in ``2μ`` and ``λ``
(:func:`neurofuzzy.simulation.tangents.unit_forces`), so ``∂F/∂θ`` needs no differencing.

What the data cannot tell is said, not guessed: under displacement control with no force
measured and no load, the equilibrium does not depend on the stiffness's scale
(``∂p/∂ log E = 0`` exactly), so Young's modulus is listed in ``unidentifiable_`` and kept at
its start value; Poisson's ratio (and the law's shape) still are identified. Scans taken at
separate load steps are seldom registered exactly to each other: a rigid transform per step
(a nuisance, on by default) moves each scan onto the model's markers before the residual is
taken (Kabsch's closed form, alternating with the material's steps).

An indenter (``LoadSteps.tool``, :mod:`neurofuzzy.simulation.contact`) presses the body at
each step and the load cell reads its force. The contact's penalty scales with E, so without
that force the markers cannot tell E through the penalty's give; the force's derivative is
the contact's stiffness times the positions' plus, by log E, the force itself.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..load_steps import tool_at
from ..model import Model
from ..simulation.static import equilibrium
from ..simulation.tangents import unit_forces
from ._load_step_result import LoadStepFit
from ._load_step_noise import beyond_rigid, kabsch, marker_rms as rms_of, residual_noise
from ._reference_scan import MarkerGradients, project

__all__ = ["LoadStepFit", "fit_load_steps"]

#: the parameters, in the order of the fit's vector (log E, then u with ν = 0.5 σ(u))
PARAMETERS = ("youngs_modulus", "poisson_ratio")
#: what equilibria never tell: the viscosity (nothing moves) and the density (nothing
#: accelerates)
STATIC_UNIDENTIFIABLE = ("viscosity", "density")
#: the least relative fall of the cost that counts as progress: below it the fit has
#: converged (a fall of 1e-7 of χ² moves E and ν by far less than their standard errors)
GAIN = 1e-7


def _constants(theta):
    """``(E, ν, shear 2μ, λ, ∂(2μ, λ)/∂θ)`` of ``θ = (log E, u)``."""
    E = float(np.exp(theta[0]))
    nu = 0.5 / (1.0 + np.exp(-theta[1]))
    shear = E / (1 + nu)
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    dnu = nu * (1 - 2 * nu)
    derivatives = np.array([[shear, -E / (1 + nu) ** 2 * dnu],
                            [lam, E * (1 + 2 * nu**2) / ((1 + nu) * (1 - 2 * nu)) ** 2 * dnu]])
    return E, nu, shear, lam, derivatives


def _start_modulus(model) -> float:
    return float(np.max(model.elements.youngs_modulus))


def _forward(model, data, theta, steps, want_jacobian, warm=None, gradient_of=None):
    """The model of ``θ`` through every step: markers (n_steps, n_markers, 3), the first
    driven set's reaction or the tool's force (n_steps, 3), their derivatives by θ, each
    marker's deformation gradient per step (by ``gradient_of``, a :class:`MarkerGradients`;
    else None). ``warm`` (step → (positions, factorisation)) holds the equilibria of a nearby
    ``θ``: each step's Newton starts there (one or two iterations instead of a solve from the
    last step), solving with that step's factorisation as GMRES's preconditioner; updated."""
    E, nu, _, _, dconst = _constants(theta)
    current = model.with_elements(youngs_modulus=E, poisson_ratio=nu)
    H = (sp.csr_matrix((0, model.n_nodes)) if data.markers is None
         else data.markers.operator(model.n_nodes))
    tool, touch, measured_set = data.tool, None, None
    if tool is not None:            # the penalty scales with E: the markers then cannot tell E
        touch = tool.contact(model)
        touch = replace(touch, stiffness=touch.stiffness * E / _start_modulus(model))
    else:
        measured_set = np.asarray(data.driven[0].nodes)
    markers, reactions, d_markers, d_reactions, gradients = [], [], [], [], []
    positions = None
    for step in range(1, max(steps) + 1):
        contact = tool_at(tool, touch, step)
        if warm is not None and step in warm:
            contact.pop("tool_start", None)
            result = equilibrium(current, driven=data.boundary(step), start=warm[step][0],
                                 factor=warm[step][1], **contact)
        else:
            result = equilibrium(current, driven=data.boundary(step), start=positions,
                                 increments=2 if step == 1 else 1,
                                 factor=None if step == 1 else result.factor, **contact)
        positions = result.positions
        if warm is not None:
            warm[step] = (positions, result.factor)
        markers.append(H @ positions)
        if gradient_of is not None:
            gradients.append(gradient_of.at(positions))
        reactions.append(result.reaction_on(measured_set) if tool is None
                         else result.contact_force)
        if not want_jacobian:
            continue
        K = result.stiffness
        held = result.held
        free = np.setdiff1d(np.arange(3 * model.n_nodes), held)
        units = unit_forces(current, positions)[0].reshape(2, -1)     # (2, 3N)
        dF = dconst.T @ units                                         # (P, 3N)
        if tool is not None:
            dF[0] += result.contact_forces.ravel()        # κ ∝ E: ∂f/∂ log E = f
        dp = np.zeros((len(theta), 3 * model.n_nodes))
        dp[:, free] = result.solve_free(dF[:, free].T).T
        d_markers.append(np.stack([H @ d.reshape(-1, 3) for d in dp]))
        if tool is not None:
            # d(Σ f)/dθ = -Σ K_tool dp, and Σ f itself by log E
            K_tool = contact["contact"].stiffness_matrix(positions)
            d_tool = -(K_tool @ dp.T).T.reshape(len(theta), -1, 3).sum(axis=1)
            d_tool[0] += result.contact_force
            d_reactions.append(d_tool)
            continue
        # reaction R_c = -(F + f)_c:  dR_c = -∂F_c/∂θ + K_cf dp_f
        on_set = np.zeros(3 * model.n_nodes, bool)
        on_set[(3 * measured_set[:, None] + np.arange(3)).ravel()] = True
        K_cf = K[held][:, free]
        dR = np.zeros((len(theta), 3 * model.n_nodes))
        dR[:, held] = -dF[:, held] + (K_cf @ dp[:, free].T).T
        dR[:, ~on_set] = 0.0
        d_reactions.append(dR.reshape(len(theta), -1, 3).sum(axis=1))
    return (current, np.array(markers), np.array(reactions), d_markers, d_reactions, warm,
            np.array(gradients) if gradient_of is not None else None)


def fit_load_steps(model: Model, data, *, marker_noise: float | None = None,
                   force_noise: float | None = None, register: bool = True,
                   reference_noise: bool = False, validate_on: Sequence[int] = (),
                   max_iterations: int = 30,
                   progress: Callable[[str], None] | None = None) -> LoadStepFit:
    """Fit the elements' Young's modulus and Poisson's ratio (one material) to
    :class:`~neurofuzzy.load_steps.LoadSteps` (module docstring).

    Parameters
    ----------
    model : Model
        The start: an element model of the specimen's mesh (its E, ν the start values, its
        law kept).
    data : LoadSteps
    marker_noise, force_noise : float, optional
        The markers' (m) and the load cell's (N) noise; estimated from the residuals and
        reported when not given.
    register : bool
        A rigid transform per scan (module docstring).
    reference_noise : bool
        True: the reference scan is as noisy as the others, and each marker's rest position
        is estimated from all the fitted scans (:mod:`._reference_scan`); a noisy reference
        otherwise puts its noise into every residual (√2 σ for a perfect model). Off by
        default: the rest positions' three numbers per marker also soak up a wrong model's
        error (on ``examples/compression_between_plates.py``'s bonded SVK model of a sliding
        gel, the RMS falls from 210 to 121 µm and the diagnosis no longer names plate slip
        first), so use it for a model already found adequate, to see its residual and
        held-out error at the noise.
    validate_on : sequence of int
        Load steps (1-based) kept out of the fit; their prediction error is reported.
    """
    say = progress or (lambda message: None)
    if model.elements is None:
        raise InputError("a fit from load steps needs an element model", key="model")
    if model.mesh is not data.mesh and model.n_nodes != data.mesh.n_nodes:
        raise InputError(f"the model has {model.n_nodes} nodes, the load steps' mesh "
                         f"{data.mesh.n_nodes}", key="model")
    held_out = sorted({int(s) for s in validate_on})
    if any(s < 1 or s > data.n_steps for s in held_out) or len(held_out) >= data.n_steps:
        raise InputError(f"validate_on must name some of the load steps 1..{data.n_steps} and "
                         f"leave one to fit; got {list(validate_on)}", key="validate_on")
    fitted = [s for s in range(1, data.n_steps + 1) if s not in held_out]
    imaged = data.markers is not None
    scans = data.markers.positions[1:] if imaged else np.zeros((data.n_steps, 0, 3))
    seen = np.isfinite(scans).all(axis=-1)
    size = float(np.ptp(model.mesh.rest_positions, axis=0).max())
    reaction = None if data.reaction is None else np.asarray(data.reaction, float)
    sigma_m = marker_noise or 1e-4 * size
    sigma_f = force_noise or (None if reaction is None
                              else max(0.01 * np.abs(reaction).max(), 1e-12))
    E0 = float(np.mean(model.elements.youngs_modulus))
    nu0 = float(np.clip(np.mean(model.elements.poisson_ratio), 0.01, 0.4999))
    theta = np.array([np.log(E0), np.log(nu0 / (0.5 - nu0))])
    transforms = np.tile(np.eye(4), (data.n_steps, 1, 1))
    iterations = 0
    warm = {}
    gradient_of = (MarkerGradients(model.mesh.rest_positions, np.asarray(data.markers.nodes))
                   if imaged and reference_noise else None)
    # the reference scan against the markers' embedded rest points (zero for an import)
    rest_misfit = (None if gradient_of is None else data.markers.positions[0]
                   - data.markers.operator(model.n_nodes) @ model.mesh.rest_positions)

    def forward(theta, steps, want_jacobian, warm):
        return _forward(model, data, theta, steps, want_jacobian, warm, gradient_of)

    def registered(markers):
        out = scans[:len(markers)].copy()
        for k in range(len(markers)):
            if register and seen[k].sum() >= 3:
                R, t = kabsch(scans[k, seen[k]], markers[k, seen[k]])
                transforms[k, :3, :3], transforms[k, :3, 3] = R, t
            out[k] = scans[k] @ transforms[k, :3, :3].T + transforms[k, :3, 3]
        return out

    def misfit(markers, gradients, d_markers=None):
        """The reference scan's residual (None when taken as exact), the scans' (measured
        minus model, registered), and their derivatives by θ."""
        moved = registered(markers) - markers
        d_moved = None if d_markers is None else -np.array(d_markers)
        for k in range(0 if d_moved is None or not register else len(d_moved)):
            if seen[k].sum() >= 3:          # the registration follows the rigid part
                d_moved[k][:, seen[k]] = beyond_rigid(markers[k][seen[k]],
                                                      d_moved[k][:, seen[k]])
        if gradients is None:
            return None, moved, None, d_moved
        return project(rest_misfit, moved, gradients, seen, fitted, d_moved)

    def residuals(markers, reactions, rows, gradients):
        reference, moved = misfit(markers, gradients)[:2]
        r = [] if reference is None else [(reference / sigma_m).ravel()]
        r += [(moved[s - 1][seen[s - 1]] / sigma_m).ravel() for s in rows]
        if reaction is not None:
            r += [(reaction[s - 1] - reactions[s - 1]) / sigma_f for s in rows]
        return np.concatenate(r)

    def jacobian(markers, gradients, d_markers, d_reactions):
        _, _, d_reference, d_moved = misfit(markers, gradients, d_markers)
        blocks = [] if d_reference is None else [(d_reference / sigma_m).reshape(len(theta),
                                                                                 -1)]
        blocks += [(d_moved[s - 1][:, seen[s - 1]] / sigma_m).reshape(len(theta), -1)
                   for s in fitted]
        if reaction is not None:
            blocks += [-(d_reactions[s - 1] / sigma_f) for s in fitted]
        return np.concatenate(blocks, axis=1).T

    estimate = marker_noise is None or (reaction is not None and force_noise is None)
    # the noise estimated from the residuals, then a refit: its scale moves the minimum only
    # where it weighs the markers against the load cell
    rounds = 2 if estimate and imaged and reaction is not None else 1
    identifiable = np.ones(len(theta), bool)
    for round_ in range(rounds):
        damping = 1e-3
        current, markers, reactions, dm, dr, warm, grads = forward(theta, fitted, True, warm)
        r = residuals(markers, reactions, fitted, grads)
        cost = r @ r
        for _ in range(max_iterations):
            J = jacobian(markers, grads, dm, dr)
            norms = np.linalg.norm(J, axis=0)
            identifiable = norms > 1e-7 * max(norms.max(), 1e-300)
            identifiable[1] &= imaged                  # a force curve alone: ν held
            J = J[:, identifiable]
            g = J.T @ r
            A = J.T @ J
            accepted = False
            while damping < 1e10:
                step = np.zeros(len(theta))
                step[identifiable] = -np.linalg.solve(A + damping * np.diag(np.diag(A)), g)
                move = step[identifiable]
                if -(2 * g @ move + move @ A @ move) < GAIN * cost:
                    break           # the linearised model promises no gain worth a solve
                trial = theta + np.clip(step, -1.0, 1.0)
                out = forward(trial, fitted, True, dict(warm))
                r_trial = residuals(out[1], out[2], fitted, out[6])
                if r_trial @ r_trial < cost:
                    theta, (current, markers, reactions, dm, dr, warm, grads) = trial, out
                    gain = (cost - r_trial @ r_trial) / max(cost, 1e-300)
                    r, cost, accepted = r_trial, r_trial @ r_trial, gain > GAIN
                    damping = max(damping / 10, 1e-9)
                    break
                damping *= 10
            iterations += 1
            E, nu = _constants(theta)[:2]
            say(f"  load steps: iteration {iterations}, cost {cost:.6g}, E {E:.4g} Pa, "
                f"nu {nu:.4f}")
            if not accepted or np.abs(step).max() < 1e-8:
                break
        if estimate and round_ == 0:
            reference, moved = misfit(markers, grads)[:2]
            sigma_m, sigma_f = residual_noise(moved, reference, seen, fitted, reactions,
                                              reaction, sigma_m, sigma_f, marker_noise,
                                              force_noise, register, int(identifiable.sum()))
    J = jacobian(markers, grads, dm, dr)[:, identifiable]
    covariance = np.linalg.pinv(J.T @ J)
    E, nu, *_ = _constants(theta)
    errors = {}
    names = [name for name, keep in zip(PARAMETERS, identifiable) if keep]
    scale = {"youngs_modulus": E, "poisson_ratio": nu * (1 - 2 * nu)}
    for i, name in enumerate(names):
        errors[name] = float(np.sqrt(covariance[i, i]) * scale[name])
    moved = misfit(markers, grads)[1]
    marker_rms = rms_of(moved, seen, fitted) if imaged else None
    force_rms = None if reaction is None else float(np.sqrt(np.mean(
        (reaction[[s - 1 for s in fitted]] - reactions[[s - 1 for s in fitted]]) ** 2)))
    validation = None
    everything = forward(theta, range(1, data.n_steps + 1), False, warm)
    scans_all = registered(everything[1])
    moved_all = misfit(everything[1], everything[6])[1]
    if held_out:
        validation = {"steps": held_out, "fitted_rms_error": marker_rms,
                      "rms_error": rms_of(moved_all, seen, held_out) if imaged else None}
        if reaction is not None:
            validation["force_error"] = float(np.sqrt(np.mean(
                (reaction[[s - 1 for s in held_out]]
                 - everything[2][[s - 1 for s in held_out]]) ** 2)))
    notes = ["static steps: viscosity and density play no part (not identifiable, given no "
             "word), and Prony terms take their long-time value"]
    if not imaged:
        notes.append(f"no markers: Poisson's ratio is held at the start's {nu:.4g} (from the "
                     "words or the model file) and Young's modulus fitted to the force alone")
    if not identifiable[0]:
        notes.append("no force was measured and no load applied: under displacement control "
                     "the equilibrium does not depend on the stiffness's scale, so Young's "
                     "modulus cannot be identified (add a load cell's force)")
    if data.tool is not None:
        notes += _contact_note(model, data.tool)
    fixed = () if imaged else ("poisson_ratio",)
    unidentifiable = tuple(n for n, keep in zip(PARAMETERS, identifiable)
                           if not keep and n not in fixed)
    return LoadStepFit(current, E, nu, errors, unidentifiable + STATIC_UNIDENTIFIABLE,
                       marker_rms, force_rms, float(sigma_m) if imaged else None,
                       None if sigma_f is None else float(sigma_f), transforms.copy(),
                       validation, iterations, tuple(notes),
                       np.where(np.isnan(moved_all), everything[1], scans_all - moved_all),
                       everything[2], scans_all, tuple(fitted), fixed,
                       marker_noise is None and imaged)


def _contact_note(model: Model, path) -> list[str]:
    """A note when a sphere's contact is spanned by too few cells of the mesh
    (:func:`~neurofuzzy.simulation.contact.cells_across_contact`): there linear tetrahedra
    are too stiff, E comes out low, and neither the residual nor the standard errors show it."""
    from ..simulation.contact import RESOLVED, cells_across_contact

    across = cells_across_contact(model.mesh, path.tool, path.positions)
    if across is None or across[1] >= RESOLVED:
        return []
    a, cells = across
    return [f"the {path.name}'s contact radius at its shallowest step ({1e3 * a:.2g} mm, "
            f"Hertz's √(R δ)) spans {cells:.1f} cells of the mesh under it, fewer than "
            f"{RESOLVED:g}: linear tetrahedra that coarse are too stiff under the tool, so "
            "Young's modulus comes out low by more than its standard error (measured on a "
            "graded block: 15 % low with 2.3 cells, 1.8 % with 5.0); refine the mesh under "
            "the tool"]
