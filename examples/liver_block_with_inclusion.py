"""Recordings of a liver block with a hidden stiff inclusion: the data of the prior
walkthrough (docs/tutorials/prior.md).

Run:  python examples/liver_block_with_inclusion.py [OUT_DIR]

Writes OUT_DIR/push.npz and OUT_DIR/pull.npz (default: the current folder): a 3 x 3 x 2 cm
block of tetrahedral elements (six per 1 cm cell), bottom fixed, of healthy liver (E = 5 kPa,
"firm"; ν 0.45, η 2 Pa·s, 1050 kg/m³) except the centre cell of the top layer, 5 times stiffer
("hard"); pushed down and pulled sideways by 30 mN spread over the top nodes, 21 frames of
2 ms, every node recorded with 10 µm noise per coordinate (seeded).
"""

import sys
from pathlib import Path

import numpy as np

import neurofuzzy as nf
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.learn import auto_substeps

FIRM, HARD = 5000.0, 25000.0   # Pa: the liver rule base's "firm", and 5x that ("hard")


def recordings(out: Path) -> list[Path]:
    mesh = nf.from_tetra(*kuhn_block((3, 3, 2), 0.01)).with_fixed(
        where=lambda p: p[:, 2] < 1e-9)
    centres = mesh.rest_positions[mesh.tetrahedra].mean(axis=1)
    inside = np.all((centres > 0.01) & (centres < 0.02), axis=1)
    truth = nf.Model.continuum(mesh, youngs_modulus=np.where(inside, HARD, FIRM),
                               poisson_ratio=0.45, viscosity=2.0, density=1050.0)
    top = np.flatnonzero(mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9)
    dt = 2e-3
    substeps = auto_substeps(truth, dt)
    written = []
    for seed, (name, direction) in enumerate((("push", (0.0, 0.0, -1.0)),
                                              ("pull", (1.0, 0.0, 0.0)))):
        load = np.zeros((mesh.n_nodes, 3))
        load[top] = np.array(direction) * 0.03 / len(top)
        data = nf.simulate_experiment(truth, dt=dt, n_frames=21, external_forces=load,
                                      substeps=substeps, noise=1e-5, seed=seed,
                                      source=f"{name}.npz")
        written.append(nf.save_experiment(data, out / f"{name}.npz"))
    print(f"{mesh.n_nodes} nodes, {mesh.n_tetrahedra} tetrahedra, {int(inside.sum())} of them "
          f"in the inclusion (E {HARD:g} Pa; the rest {FIRM:g} Pa)")
    return written


def main(argv):
    out = Path(argv[0] if argv else ".")
    out.mkdir(parents=True, exist_ok=True)
    for path in recordings(out):
        print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
