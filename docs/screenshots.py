"""The rule studio's screenshots in docs/images/ (docs/studio.md).

Run from the repository: ``python docs/screenshots.py``. It needs the test extra
(``pip install '.[test]'``) and Debian's chromium (/usr/bin/chromium). It copies liver.yaml
and soft_tissue.yaml into a temporary folder, fits three small specimens made by our own
simulator (tetrahedral elements on a 3 x 3 x 3 lattice of healthy liver, fibrotic liver and a
tumour, each fitted from the rule base's 'liver') to have real fit results, and photographs
the main views.
"""

from __future__ import annotations

import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def fitted(rules, truth_tissue: str, specimen: str, group: str) -> dict:
    """A fit-many record of a lattice of ``truth_tissue`` fitted from 'liver'."""
    import neurofuzzy as nf
    from neurofuzzy.pipeline.learners import fit_summary

    from neurofuzzy.mesh import lattice_to_tetra

    mesh = lattice_to_tetra(nf.lattice((3, 3, 3), spacing=0.01).with_fixed(
        where=nf.bottom_layer))
    truth = nf.initialize(rules, mesh, truth_tissue, elements=True)
    load = np.zeros((27, 3))
    load[22] = (0.0, 0.0, -0.05)
    data = nf.simulate_experiment(truth, dt=5e-4, n_frames=120, external_forces=load,
                                  noise=2e-6, seed=1, substeps=20)
    start = nf.start_model([data], rules=rules, tissue="liver", tie="global")
    learner = nf.GradientLearner().fit(start.model, data)
    fit = fit_summary(learner, start, method="gradient", tie="global",
                      experiments=[f"{specimen}.npz"])
    from neurofuzzy.formatting import json_safe

    return json_safe({"format": 1, "id": specimen, "group": group, "status": "ok", "fit": fit})


def main() -> None:
    import neurofuzzy as nf
    from playwright.sync_api import sync_playwright

    IMAGES.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix="studio-shots-"))
    for name in ("liver.yaml", "soft_tissue.yaml"):
        shutil.copy(ROOT / "rules" / name, folder / name)
    rules = nf.load_rules(folder / "liver.yaml")
    for specimen, group, tissue in (("s1", "healthy", "liver"), ("s2", "fibrotic",
                                                                 "fibrotic_liver"),
                                    ("s3", "fibrotic", "tumour")):
        (folder / "cohort" / specimen).mkdir(parents=True)
        record = fitted(rules, tissue, specimen, group)
        (folder / "cohort" / specimen / "fit.json").write_text(json.dumps(record))
    running = nf.studio(folder / "liver.yaml", open_browser=False, block=False, quiet=True)
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path="/usr/bin/chromium",
                                                 args=FLAGS)
            page = browser.new_page(viewport={"width": 1400, "height": 900},
                                    device_scale_factor=1)
            page.goto(running.url)
            page.wait_for_selector('tr.value[data-quantity="youngs_modulus"]')
            time.sleep(1.5)
            page.screenshot(path=IMAGES / "studio.png")

            # the output plot with the tissue's value and set, after dragging a peak
            handle = page.locator('svg.mf[data-var="youngs_modulus"] circle.handle'
                                  '[data-term="firm"][data-param="1"]')
            handle.scroll_into_view_if_needed()
            box = handle.bounding_box()
            x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            page.mouse.move(x, y)
            page.mouse.down()
            for step in range(1, 8):
                page.mouse.move(x - 5 * step, y)
                time.sleep(0.05)
            page.mouse.up()
            time.sleep(2.0)
            page.locator("#var-output-youngs_modulus").screenshot(
                path=IMAGES / "studio-drag.png")
            page.locator("aside .panel").nth(1).screenshot(path=IMAGES / "studio-block.png")

            # a problem with its line
            page.locator('input[data-tissue="fibrotic_liver"][data-input="consistency"]'
                         ).fill("very hrad")
            page.wait_for_selector("#problems li")
            time.sleep(0.5)
            page.locator("#problems").scroll_into_view_if_needed()
            page.screenshot(path=IMAGES / "studio-problem.png",
                            clip={"x": 0, "y": 0, "width": 1400, "height": 330})
            page.locator('input[data-tissue="fibrotic_liver"][data-input="consistency"]'
                         ).fill("hard")
            time.sleep(1.0)

            # the cohort beside the words
            page.select_option("#fit-select", "cohort/")
            page.click("#fit-open")
            page.locator("table.fit").wait_for()
            time.sleep(1.0)
            page.locator("#var-output-youngs_modulus").scroll_into_view_if_needed()
            page.locator("#var-output-youngs_modulus").screenshot(
                path=IMAGES / "studio-fit-plot.png")
            page.locator("aside .panel").nth(2).screenshot(path=IMAGES / "studio-fit.png")
            page.locator("#rules").scroll_into_view_if_needed()
            page.screenshot(path=IMAGES / "studio-rules.png", full_page=False)
            browser.close()
    finally:
        running.stop()
        shutil.rmtree(folder, ignore_errors=True)
    print("wrote", *sorted(p.name for p in IMAGES.glob("studio*.png")), file=sys.stderr)


if __name__ == "__main__":
    main()
