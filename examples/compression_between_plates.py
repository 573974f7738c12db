"""A gel cube compressed between plates and scanned at three load steps, in Python.

The gel (neo-Hookean, E = 6 kPa, ν = 0.47) sits on a lubricated anvil and is pressed by a
lubricated plate to 5, 12.5 and 18 %; 60 embedded beads are scanned at each step (20 µm
noise) and a load cell reads the plate (1 mN noise). The lab's model starts from the words
(bonded plates, St. Venant–Kirchhoff). The script fits the scans alone (Poisson's ratio;
Young's modulus is not identifiable without a force), then with the load cell, then asks
the diagnosis what the set-up's model lacks, and writes a report of the final fit.

    python examples/compression_between_plates.py [OUT_DIR]
"""

import sys
from pathlib import Path

import numpy as np

import neurofuzzy as nf
from neurofuzzy.mesh import kuhn_block

SIZE = 0.02                                   # a 2 cm cube
STRAINS = (0.05, 0.125, 0.18)


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    points, tetrahedra = kuhn_block((3, 3, 3), SIZE / 3)
    mesh = nf.from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    top = np.flatnonzero(np.isclose(points[:, 2], SIZE))
    path = np.array([[0.0, 0.0, -s * SIZE] for s in STRAINS])
    beads = np.random.default_rng(1).uniform(0.1 * SIZE, 0.9 * SIZE, size=(60, 3))
    nodes, weights, _ = nf.embed_points(mesh, beads)
    template = nf.EmbeddedMarkers(nodes, weights, np.zeros((len(STRAINS) + 1, 60, 3)))

    # the measurement: the gel slides on the plate (held along z only)
    gel = nf.Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.47, viscosity=1.0,
                             density=1000.0, law="neo-hookean")
    measured = nf.simulate_load_steps(gel, [nf.DrivenPath(top, path, "z", "top plate")],
                                      template, marker_noise=20e-6, force_noise=1e-3, seed=3)

    # the lab's model: a bonded plate, St. Venant–Kirchhoff, E and ν from the words
    rules = nf.load_rules(nf.shipped_rules("liver"))
    start = nf.initialize(rules, mesh, "liver", elements=True)
    bonded = nf.LoadSteps(mesh, (nf.DrivenPath(top, path, "xyz", "top plate"),),
                          measured.markers, measured.reaction)
    scans_only = nf.LoadSteps(mesh, bonded.driven, bonded.markers, None)

    print("1. the scans alone")
    print(nf.fit_load_steps(start, scans_only).summary())
    print("\n2. with the load cell")
    print(nf.fit_load_steps(start, bonded).summary())
    print("\n3. what the set-up's model lacks")
    diagnosis = nf.diagnose_load_steps(start, bonded)
    print(diagnosis.summary())
    final = diagnosis.after
    print(f"\nafter the diagnosis: E {final.youngs_modulus_:.0f} Pa (gel 6000), "
          f"nu {final.poisson_ratio_:.3f} (gel 0.47)")
    report = nf.load_steps_report(start, final, diagnosis.data, out / "compression.html")
    print(f"wrote {report}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("compression-example"))
