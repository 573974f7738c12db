"""FEBio: a ``.feb`` input file, format version 4.0.

Element and attribute names as FEBio's own reader of version 4.0 parses them (read from
``febiosoftware/FEBio``: ``FEBioXML/FEBioImport.cpp`` maps the sections,
``FEBioMeshSection4``, ``FEBioMeshDomainsSection4``, ``FEBioBoundarySection3``,
``FEBioLoadsSection3``, ``FEBioLoadDataSection3``, ``FEBioDiscreteSection25`` read them, and
the parameter names are the classes' ``ADD_PARAMETER`` names);
``tests/test_export_formats.py`` checks written files against a table of that structure and
reads the model and the load back from them:

- ``Module type="solid"``; ``Control``: ``analysis`` DYNAMIC (STATIC for a spring network,
  which has no mass in FEBio), ``time_steps`` and ``step_size`` of the experiment's frames;
- ``Mesh``: ``Nodes``, one ``Elements type="tet4"`` part per region and material, a
  ``NodeSet`` of the fixed nodes and one per loaded node, ``DiscreteSet`` of springs;
- ``Material`` per part: ``isotropic elastic`` (``E``, ``v``, ``density``), which is
  St. Venant–Kirchhoff (σ = J⁻¹ F (λ tr E I + 2μ E) Fᵀ, ``FEIsotropicElastic::Stress``) as
  our element, or ``neo-Hookean`` (``E``, ``v``) for neo-Hookean elements, FEBio's coupled
  compressible neo-Hookean solid as ours, or ``Yeoh`` (``c1`` = C₁₀, ``c2`` = C₂₀, bulk
  modulus ``k`` with ``pressure_model`` 2, Abaqus' ``K/2 (J - 1)²``: ``FEYeoh`` and
  ``FEUncoupledMaterial::U``) for Yeoh elements, our law, and ``Mooney-Rivlin`` (``c1`` =
  C₁₀, ``c2`` = C₀₁, ``k`` likewise: ``FEMooneyRivlin``) for Mooney–Rivlin elements (each
  law's ``febio`` in :data:`neurofuzzy.forces.laws.LAW_RECORDS`); with viscosity a
  ``solid mixture`` of it and a ``Newtonian viscous solid`` of shear viscosity ``mu`` = βμ
  and bulk viscosity ``kappa`` = βK (β = η/E, K the bulk modulus), our Kelvin–Voigt stress
  at small strain (FEBio's viscous stress is Cauchy in the rate of deformation, ours second
  Piola–Kirchhoff in the Green strain rate); elements that relax wrap their law in FEBio's
  ``viscoelastic`` solid (``g1``, ``t1``, … and the law as its ``elastic``: the same Prony
  convention as :mod:`neurofuzzy.forces.relaxation`, g0 = 1);
  density per region from the node masses (:func:`~neurofuzzy.export.base.region_densities`);
- ``Boundary``: ``zero displacement`` of the fixed nodes;
- ``Loads``: ``nodal_force`` per loaded node with a ``value lc="k"``, the load decomposed into
  a few load curves (:func:`~neurofuzzy.export.base.load_components`, exact to round-off),
  each a ``loadcurve`` with ``STEP`` interpolation holding frame t's force until t + 1
  (FEBio's STEP returns the value of the next point, so the point at ``(t+1) dt`` carries
  frame t's value); gravity as a ``body force`` (FEBio assembles ``-ρ f`` for a body force
  and ``+f`` for a nodal force, so ``force`` is minus the acceleration);
- springs as ``discrete`` sets of ``linear spring`` (``E`` is the stiffness, N/m), one per
  distinct stiffness.

What FEBio does differently: an implicit Newmark integrator with the consistent mass of the
density (ours: semi-implicit Euler, lumped masses), the textbook per-element tetrahedron, no
damping for discrete springs and no point masses (a spring network is written for a static
analysis). FEBio cannot be installed here: the file was checked against the reader's
structure, never run.
"""

from __future__ import annotations

import numpy as np
from xml.sax.saxutils import quoteattr

from ..forces.springs import spring_constants
from ..forces.laws import LAW_RECORDS
from .base import load_components, material_groups, prepare, region_densities, time_step
from .metadata import header_lines, volumetric_note

__all__ = ["feb", "FORMAT_VERSION"]

FORMAT_VERSION = "4.0"

def _vector(values) -> str:
    return ",".join(map(repr, np.asarray(values, dtype=float).ravel().tolist()))


def feb(model, *, experiment=None, fit: dict | None = None, substeps="auto",
        max_materials: int = 256) -> tuple[str, list[str]]:
    """The ``.feb`` text of ``model`` and the notes on what it could not express.

    Parameters are those of :func:`neurofuzzy.export.mujoco.mjcf`; ``substeps`` only sets the
    time step in the header (FEBio's implicit solver steps frame by frame).
    """
    prepared = prepare(model)
    runs = prepared.model
    if runs.elements is not None:
        runs = runs.with_elements(volumetric="element")
    h, steps = time_step(runs, experiment, substeps)
    notes = list(prepared.notes)
    if prepared.node_drag:
        notes.append("node_drag is not exported: FEBio has no per-node drag")
    note = volumetric_note(prepared.model, "FEBio", experiment, steps)
    if note:
        notes.append(note)
    mesh = runs.mesh
    stiffness, damping, rest_length = spring_constants(runs)
    springs = np.flatnonzero(stiffness > 0)
    if np.any(damping > 0):
        notes.append("spring damping is not exported: FEBio's discrete springs have none")
    rest = np.linalg.norm(np.diff(mesh.rest_positions[mesh.springs[springs]], axis=1), axis=-1)
    if springs.size and not np.allclose(rest.ravel(), rest_length[springs],
                                        rtol=1e-9, atol=0):
        notes.append("FEBio's springs rest at their initial length; ours with another rest "
                     "length start pre-stressed in neurofuzzy but not in FEBio")
    groups, densities = [], None
    if runs.elements is not None:
        groups, merged = material_groups(runs, max_materials)
        notes += merged
        notes += [LAW_RECORDS[law].febio_note
                  for law in sorted({group.law for group in groups})
                  if LAW_RECORDS[law].febio_note]
        densities, mismatch = region_densities(runs)
        if mismatch > 1e-6:
            notes.append(f"FEBio takes a density per material: the node masses are matched "
                         f"by region densities to within {100 * mismatch:.2g} %")
        notes.append("FEBio's implicit dynamics use the consistent mass of the density "
                     "(neurofuzzy lumps it) and Newmark integration (neurofuzzy: "
                     "semi-implicit Euler)")
    else:
        notes.append("a spring network has no mass in FEBio (no point masses): written for a "
                     "static analysis under the load curves")
        if np.any(prepared.gravity):
            notes.append("gravity is not exported: without elements FEBio has no mass for it "
                         "to act on")
    frames = experiment.n_frames if experiment is not None else 101
    frame_dt = experiment.dt if experiment is not None else h
    forces = (experiment.forces_per_frame() if experiment is not None
              else np.zeros((frames, mesh.n_nodes, 3))) + prepared.constant_load[None]
    curves, patterns = load_components(forces)

    header = header_lines(model, target="febio", fit=fit, notes=notes, experiment=experiment,
                          time_step=frame_dt, steps=None)
    out = ['<?xml version="1.0" encoding="ISO-8859-1"?>',
           "<!--\n" + "\n".join(header).replace("--", "- -") + "\n-->",
           f'<febio_spec version="{FORMAT_VERSION}">',
           '  <Module type="solid"/>',
           "  <Control>",
           f"    <analysis>{'DYNAMIC' if groups else 'STATIC'}</analysis>",
           f"    <time_steps>{frames - 1}</time_steps>",
           f"    <step_size>{frame_dt!r}</step_size>",
           "    <plot_zero_state>1</plot_zero_state>",
           '    <solver type="solid"/>',
           "  </Control>"]
    out += _materials(groups, densities, runs)
    out += _mesh(mesh, groups, springs, patterns, runs)
    if groups:
        out += ["  <MeshDomains>"] + [
            f'    <SolidDomain name={quoteattr(g.name)} mat={quoteattr(g.name)}/>'
            for g in groups] + ["  </MeshDomains>"]
    if len(mesh.fixed):
        out += ["  <Boundary>",
                '    <bc name="fixed" type="zero displacement" node_set="fixed">'
                "<x_dof>1</x_dof><y_dof>1</y_dof><z_dof>1</z_dof></bc>",
                "  </Boundary>"]
    out += _loads(patterns, prepared.gravity if groups else np.zeros(3))
    out += _discrete(springs, runs)
    if len(curves):
        out.append("  <LoadData>")
        times = np.arange(frames) * frame_dt
        for k, curve in enumerate(curves):
            held = np.concatenate([curve[:1], curve[:-1]])        # point t carries frame t-1
            points = "".join(f"<pt>{t!r},{v!r}</pt>" for t, v in zip(times.tolist(),
                                                                    held.tolist()))
            out.append(f'    <load_controller id="{k + 1}" name="load_curve_{k + 1}" '
                       f'type="loadcurve"><interpolate>STEP</interpolate><extend>CONSTANT'
                       f"</extend><points>{points}</points></load_controller>")
        out.append("  </LoadData>")
    out += ["  <Output>", '    <plotfile type="febio"><var type="displacement"/>'
            '<var type="stress"/></plotfile>', "  </Output>", "</febio_spec>"]
    return "\n".join(out) + "\n", notes


def _materials(groups, densities, runs) -> list[str]:
    if not groups:
        return []
    out = ["  <Material>"]
    for index, group in enumerate(groups, start=1):
        E, nu, beta = group.youngs_modulus, group.poisson_ratio, group.damping_time
        density = float(densities[group.region])
        # the law's record: isotropic elastic (E, v) is St. Venant-Kirchhoff, neo-Hookean
        # (E, v) the coupled compressible solid (FENeoHookean), ours; Yeoh and Mooney-Rivlin
        # (c1, c2, k) the uncoupled solids with Abaqus' volumetric energy (pressure_model 2)
        kind, elastic = LAW_RECORDS[group.law].febio(E, nu, group.stiffening)
        if group.relaxation:
            # FEBio's viscoelastic solid: the same convention as ours (g0 = 1, the elastic
            # law the long-term response), the law inside it
            terms = "".join(f"<g{k}>{g!r}</g{k}><t{k}>{t!r}</t{k}>"
                            for k, (g, t) in enumerate(group.relaxation, start=1))
            elastic = f'{terms}<elastic type="{kind}">{elastic}</elastic>'
            kind = "viscoelastic"
        if beta > 0:
            mu = beta * E / (2 * (1 + nu))                  # β μ, Pa·s
            kappa = beta * E / (3 * (1 - 2 * nu))           # β K, Pa·s
            out.append(f'    <material id="{index}" name={quoteattr(group.name)} '
                       f'type="solid mixture"><density>{density!r}</density>'
                       f'<solid type="{kind}">{elastic}</solid>'
                       f'<solid type="Newtonian viscous solid"><kappa>{kappa!r}</kappa>'
                       f"<mu>{mu!r}</mu></solid></material>")
        else:
            out.append(f'    <material id="{index}" name={quoteattr(group.name)} '
                       f'type="{kind}"><density>{density!r}</density>{elastic}'
                       "</material>")
    out.append("  </Material>")
    return out


def _mesh(mesh, groups, springs, patterns, runs) -> list[str]:
    out = ["  <Mesh>", '    <Nodes name="nodes">']
    out += [f'      <node id="{i + 1}">{_vector(p)}</node>'
            for i, p in enumerate(mesh.rest_positions)]
    out.append("    </Nodes>")
    next_id = 1
    for group in groups:
        out.append(f'    <Elements type="tet4" name={quoteattr(group.name)}>')
        for nodes in np.asarray(mesh.tetrahedra)[group.elements] + 1:
            out.append(f'      <elem id="{next_id}">{",".join(map(str, nodes.tolist()))}</elem>')
            next_id += 1
        out.append("    </Elements>")
    if len(mesh.fixed):
        out.append(f'    <NodeSet name="fixed">{",".join(str(i + 1) for i in mesh.fixed)}'
                   "</NodeSet>")
    for node in _loaded(patterns):
        out.append(f'    <NodeSet name="load_node_{node + 1}">{node + 1}</NodeSet>')
    for k, members in enumerate(_spring_sets(springs, runs), start=1):
        out.append(f'    <DiscreteSet name="springs_{k}">' + "".join(
            f"<delem>{a + 1},{b + 1}</delem>" for a, b in mesh.springs[members].tolist())
            + "</DiscreteSet>")
    out.append("  </Mesh>")
    return out


def _loaded(patterns) -> np.ndarray:
    if not len(patterns):
        return np.zeros(0, int)
    return np.flatnonzero(np.any(patterns != 0, axis=(0, 2)))


def _loads(patterns, gravity) -> list[str]:
    loads = []
    for node in _loaded(patterns):
        for k, pattern in enumerate(patterns, start=1):
            if np.any(pattern[node]):
                loads.append(f'    <nodal_load name="load_{k}_node_{node + 1}" type="nodal_force" '
                             f'node_set="load_node_{node + 1}"><value lc="{k}">'
                             f"{_vector(pattern[node])}</value></nodal_load>")
    if np.any(gravity):
        loads.append(f'    <body_load name="gravity" type="body force"><force>'
                     f"{_vector(-np.asarray(gravity))}</force></body_load>")
    return ["  <Loads>", *loads, "  </Loads>"] if loads else []


def _spring_sets(springs, runs) -> list[np.ndarray]:
    """Springs grouped by equal stiffness (one FEBio discrete material each)."""
    if not springs.size:
        return []
    _, inverse = np.unique(spring_constants(runs)[0][springs], return_inverse=True)
    return [springs[inverse.ravel() == k] for k in range(inverse.max() + 1)]


def _discrete(springs, runs) -> list[str]:
    sets = _spring_sets(springs, runs)
    if not sets:
        return []
    out = ["  <Discrete>"]
    for k, members in enumerate(sets, start=1):
        out.append(f'    <discrete_material id="{k}" name="spring_{k}" type="linear spring">'
                   f"<E>{float(spring_constants(runs)[0][members[0]])!r}</E>"
                   "</discrete_material>")
    out += [f'    <discrete dmat="{k}" discrete_set="springs_{k}"/>'
            for k in range(1, len(sets) + 1)]
    out.append("  </Discrete>")
    return out
