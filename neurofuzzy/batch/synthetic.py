"""A synthetic cohort made with our own simulator, for the example and the tests.

Every specimen is a lattice block of one group's tissue (a shipped rule base's start values),
its stiffness and viscosity varied by a seeded log-normal factor, pushed on its top centre
node from rest and recorded with Gaussian marker noise. The manifest asks for the fit an
expert would start: one tissue's words for every specimen, tied globally.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["SyntheticCohort", "synthetic_cohort"]


@dataclass(frozen=True)
class SyntheticCohort:
    """What :func:`synthetic_cohort` wrote.

    Attributes
    ----------
    manifest : Path
        ``cohort.csv``.
    truth : dict
        Specimen id → ``{"group", "tissue", "youngs_modulus", "viscosity", "density",
        "words"}`` of the model that made its data (``words``: the rule base's word per
        quantity).
    """

    manifest: Path
    truth: dict


def synthetic_cohort(folder, *, groups: dict | None = None, per_group: int = 3,
                     shape=(3, 3, 3), spacing: float = 0.01, spread: float = 0.15,
                     noise: float = 5e-6, force: float = 0.05, dt: float = 5e-4,
                     n_frames: int = 120, rules: str = "liver", expert: str = "liver",
                     substeps: int | str = 1, seed: int = 0) -> SyntheticCohort:
    """Write experiment files and a manifest (``cohort.csv``) of a synthetic cohort.

    Parameters
    ----------
    folder : path
        Created if needed; the experiments go to ``folder/data/<id>.npz``.
    groups : dict, optional
        Group label → true tissue of the rule base (default ``{"healthy": "liver",
        "fibrotic": "fibrotic_liver"}``).
    per_group : int
        Specimens per group.
    shape, spacing
        The lattice (nodes per axis, metres); bottom layer fixed, body diagonals.
    spread : float
        Standard deviation of the log of the per-specimen factors on stiffness and viscosity.
    noise : float
        Marker noise (m, standard deviation per coordinate).
    force : float
        Downward push on the top centre node (N).
    dt, n_frames
        Frame spacing (s) and frames of each recording.
    rules, expert : str
        The shipped rule base and the tissue every fit starts from (the expert's guess).
    substeps : int or "auto"
        The fits' ``substeps`` option (the data are made at one step per frame).
    seed : int
        Seed of the variation and the noise.
    """
    from ..datasets import point_load, top_centre_node
    from ..experiment import simulate_experiment
    from ..io import save_experiment
    from ..mesh import bottom_layer, lattice
    from ..rules import resolve
    from ..tissues import initialize, materials

    groups = {"healthy": "liver", "fibrotic": "fibrotic_liver"} if groups is None else groups
    folder = Path(folder)
    rule_base = resolve(rules)
    mesh = lattice(tuple(shape), spacing, diagonals="body").with_fixed(where=bottom_layer)
    load = point_load(mesh, top_centre_node(mesh), (0.0, 0.0, -force))
    rng = np.random.default_rng(seed)
    lines = ["id,group,experiments,rules,tissue,tie,substeps"]
    truth = {}
    for group, tissue in groups.items():
        base = initialize(rule_base, mesh, tissue).tied("global")
        for index in range(per_group):
            ident = f"{group}-{index + 1:02d}"
            stiffness, damping = np.exp(rng.normal(0.0, spread, 2))
            springs = base.springs
            model = base.with_term(springs.replace(stiffness=springs.stiffness * stiffness,
                                                   damping=springs.damping * damping))
            experiment = simulate_experiment(model, dt=dt, n_frames=n_frames,
                                             external_forces=load, noise=noise,
                                             seed=int(rng.integers(2**31)),
                                             source=f"data/{ident}.npz")
            save_experiment(experiment, folder / "data" / f"{ident}.npz")
            values = materials(model, rule_base)[tissue]
            truth[ident] = {"group": group, "tissue": tissue, "words": values["labels"],
                            **{q: values[q] for q in ("youngs_modulus", "viscosity",
                                                      "density")}}
            lines.append(f"{ident},{group},data/{ident}.npz,{rules},{expert},global,{substeps}")
    manifest = folder / "cohort.csv"
    manifest.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return SyntheticCohort(manifest, truth)
