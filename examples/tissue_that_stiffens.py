"""Tissue that stiffens as it is pressed: from words to Yeoh elements, fitted on another solver's
data, and back to words.

The data: sfepy's uncoupled Yeoh block (4 x 4 x 3 cm, E = 6 kPa, nu = 0.45, C20 = C10,
viscosity 2 Pa s, bottom held) pressed by 0.7 N through a 1 cm patch, 25 % compression under
the probe at its deepest, 148 surface markers at 1 kHz with 20 um noise
(``tests/data/stiffening_block.npz``, made by ``neurofuzzy.validation.nonlinear``).

The steps: a rule base describes the tissue as "firm, stiffens moderately when compressed";
its words make the start model (Yeoh elements with the inferred C20/C10) on voxels a user would
build from the block's surface; the same start is fitted with each law; each fit's marker error
is compared with the noise, and the fitted numbers come back as words.

Run:  python examples/tissue_that_stiffens.py OUT_DIR [--pitch 0.0075]
"""

import argparse
import time
from pathlib import Path

import numpy as np

import neurofuzzy as nf
from neurofuzzy.validation.nonlinear.recordings import stored
from neurofuzzy.validation.probed_block import block_experiment, block_model
from neurofuzzy.rules import load_rules
from neurofuzzy.tissues import materials

ROOT = Path(__file__).resolve().parents[1]
RECORDING = ROOT / "tests" / "data" / "stiffening_block.npz"
RULES = """extends: {shared}
name: stiffening tissue
tissues:
  stiffening_liver: {{consistency: firm, elasticity: elastic, heaviness: normal,
                     compressibility: incompressible, stiffening: moderately}}
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--pitch", type=float, default=0.0075,
                        help="voxel size of the user's mesh (m); 0.0033 takes minutes")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rules_path = args.out / "stiffening.yaml"
    rules_path.write_text(RULES.format(shared=ROOT / "rules" / "soft_tissue.yaml"))
    rules = load_rules(rules_path)

    recording = stored(RECORDING)
    truth = recording.truth
    start = block_model(pitch=args.pitch, rules=str(rules_path),
                        tissue="stiffening_liver").tied("global")
    experiment = block_experiment(recording, start.mesh)
    said = rules.tissue("stiffening_liver")
    print(f"the words give: E {said['youngs_modulus']:.0f} Pa, C20/C10 "
          f"{said['strain_stiffening']:.2f} (law {start.elements.law_names()})")
    print(f"the truth:      E {truth['youngs_modulus']:.0f} Pa, C20/C10 "
          f"{truth['c20'] / truth['c10']:.2f} ({truth['law']} by {truth['solver']})")
    print(f"{'law':<21}{'E (Pa)':>9}{'nu':>7}{'C20/C10':>9}{'RMS/noise':>11}{'s':>5}  words")
    for law in ("st-venant-kirchhoff", "neo-hookean", "yeoh"):
        began = time.perf_counter()
        fitted = nf.fit(experiment, start=start.with_elements(law=law), tie="global")
        model = fitted.model
        [region] = materials(model, rules, "stiffening_liver").values()
        words = region["labels"]
        stiffening = (f"{np.median(model.elements.stiffening):.2f}" if law == "yeoh" else "")
        print(f"{law:<21}{np.median(model.elements.youngs_modulus):>9.0f}"
              f"{np.median(model.elements.poisson_ratio):>7.3f}{stiffening:>9}"
              f"{fitted.learner.lack_of_fit_.ratio:>10.2f}x"
              f"{time.perf_counter() - began:>5.0f}  youngs_modulus {words['youngs_modulus']}"
              + (f", strain_stiffening {words['strain_stiffening']}" if law == "yeoh" else ""))
        nf.save_model(model, args.out / f"fitted_{law}.yaml")
    print(f"fitted models in {args.out}")


if __name__ == "__main__":
    main()
