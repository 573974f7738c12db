"""The rule studio in a real browser: headless Chromium (Debian's package) driven by
Playwright's Python driver.

On a machine without /usr/bin/chromium or playwright the test is skipped, except where
NEUROFUZZY_BROWSER_TESTS=required (set by .ci/run, which installs both): there it fails.
"""

import json
import os
import shutil
import time
from pathlib import Path

import pytest
from helpers import cli

from neurofuzzy.rules import load_rules

pytestmark = pytest.mark.slow

RULES = Path(__file__).resolve().parents[1] / "rules"
CHROMIUM = os.environ.get("NEUROFUZZY_CHROMIUM", "/usr/bin/chromium")
#: the flags this machine's headless Chromium needs (no sandbox as root, no network chatter)
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _unavailable(why: str):
    if os.environ.get("NEUROFUZZY_BROWSER_TESTS") == "required":
        pytest.fail(f"browser tests are required here but {why}")
    pytest.skip(why)


@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable("playwright is not installed (pip install 'neurofuzzy[test]')")
    if not Path(CHROMIUM).exists():
        _unavailable(f"{CHROMIUM} is missing (apt-get install chromium)")
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        yield chromium
        chromium.close()


@pytest.fixture
def studio(tmp_path):
    import neurofuzzy as nf

    for name in ("liver.yaml", "soft_tissue.yaml"):
        shutil.copy(RULES / name, tmp_path / name)
    running = nf.studio(tmp_path / "liver.yaml", open_browser=False, block=False, quiet=True)
    yield running, tmp_path
    running.stop()


def modulus(page) -> float:
    return float(page.get_attribute('tr.value[data-quantity="youngs_modulus"]', "data-value"))


def depth(page) -> float:
    return float(page.get_attribute("#block", "data-depth"))


def until(condition, timeout=15.0):
    """Poll ``condition()`` from Python until it is true (the page's Content-Security-Policy
    forbids the eval behind Playwright's wait_for_function, as it should)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {condition.__doc__ or condition}")
        time.sleep(0.05)


def settled(page):
    """Wait until the page has no edit, tissue or block request under way (twice, so that
    a request started by the last response is waited for too)."""
    for _ in range(2):
        until(lambda: attribute(page, "body", "data-busy") == "0")
        time.sleep(0.1)


def attribute(page, selector, name):
    element = page.query_selector(selector)
    return element.get_attribute(name) if element else None


def test_edit_a_breakpoint_see_the_tissue_fix_an_error_and_save(browser, studio):
    running, folder = studio
    original = (folder / "liver.yaml").read_text()
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    page.on("pageerror", lambda error: errors.append(f"{error} {error.stack}"))
    page.goto(running.url)

    # the liver as the shipped words make it, and its block
    page.wait_for_selector('tr.value[data-quantity="youngs_modulus"]')
    until(lambda: attribute(page, "#block", "data-tissue") == "liver")
    settled(page)
    start_modulus, start_depth = modulus(page), depth(page)
    assert 3000 < start_modulus < 8000 and start_depth > 0
    assert page.inner_text('tr.value[data-quantity="youngs_modulus"]').count("kPa") == 1

    # drag the peak of youngs_modulus 'firm' to the left: E falls, the block sinks deeper
    handle = page.locator('svg.mf[data-var="youngs_modulus"] circle.handle'
                          '[data-term="firm"][data-param="1"]')
    handle.scroll_into_view_if_needed()
    box = handle.bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for step in range(1, 9):
        page.mouse.move(x - 6 * step, y)
        time.sleep(0.03)
    page.mouse.up()
    until(lambda: modulus(page) < 0.93 * start_modulus)
    until(lambda: depth(page) > 1.04 * start_depth)
    settled(page)
    dragged_modulus = modulus(page)
    peak = float(page.input_value('input.param[data-var="youngs_modulus"][data-term="firm"]'
                                  '[data-param="1"]'))
    assert peak < 5000
    assert page.is_visible('#var-output-youngs_modulus .badge.own')   # copied into liver.yaml

    # a typo in a tissue: the problem with the line it will have in the file; no saving
    words = page.locator('input[data-tissue="liver"][data-input="consistency"]')
    words.fill("frim")
    page.wait_for_selector("#problems li")
    problem = page.inner_text("#problems li")
    assert "has no term 'frim'; did you mean 'firm'?" in problem
    line = int(page.get_attribute("#problems li", "data-line"))
    assert problem.startswith(f"liver.yaml:{line}: ")
    assert "consistency: frim" in page.text_content(f"#yaml div:nth-child({line})")
    assert page.is_disabled("#save")

    # fixed: the problem goes, the tissue comes back, and the file is saved
    words.fill("firm")
    until(lambda: attribute(page, "#status", "data-problems") == "0")
    assert page.is_hidden("#problems")
    settled(page)
    page.click("#save")
    until(lambda: page.inner_text("#status").startswith("saved liver.yaml"))
    saved = (folder / "liver.yaml").read_text()
    assert saved.startswith(original)            # every line of the file kept, comments too
    added = saved[len(original):]
    assert added.startswith("outputs:\n  youngs_modulus:\n")
    assert "# liver: MR elastography shear 2.2 kPa" in added       # the extended file's comment
    assert cli("rules", "check", folder / "liver.yaml").returncode == 0
    reloaded = load_rules(folder / "liver.yaml")
    assert reloaded.outputs["youngs_modulus"].terms["firm"].params[1] == peak
    assert reloaded.tissue("liver")["youngs_modulus"] == pytest.approx(dragged_modulus)
    assert (folder / "soft_tissue.yaml").read_text() == (RULES / "soft_tissue.yaml").read_text()

    # a fit result beside the words: start and learned values, words before and after
    (folder / "fit.json").write_text(json.dumps({"materials": {"object": {
        "youngs_modulus": 30000.0, "poisson_ratio": 0.45, "viscosity": 2.0, "density": 1050.0,
        "tissue": "liver", "labels": {"youngs_modulus": "hard"}}}}))
    page.reload()
    page.wait_for_selector('#fit-select option[value="fit.json"]', state="attached")
    page.select_option("#fit-select", "fit.json")
    page.click("#fit-open")
    row = page.locator('table.fit tr[data-output="youngs_modulus"]')
    row.wait_for()
    assert "firm" in row.inner_text() and "hard" in row.inner_text()
    assert page.locator('svg.mf[data-var="youngs_modulus"] .fit-start').count() == 1
    assert errors == []


def test_the_side_panels_fit_a_1400_pixel_window(browser, studio):
    """At 1400 x 900 pixels nothing in the side panels runs past their right edge, for every
    tissue of the liver (the longest words: 'nearly_incompressible (0.72)',
    'relaxation_modulus'), and the inputs a tissue leaves out are named with the defaults
    it takes."""
    running, folder = studio
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    errors = []
    page.on("pageerror", lambda error: errors.append(f"{error} {error.stack}"))
    page.goto(running.url)
    page.wait_for_selector('tr.value[data-quantity="poisson_ratio"]')
    for tissue in load_rules(folder / "liver.yaml").tissues:
        page.select_option("#tissue-select", tissue)
        until(lambda: attribute(page, "#block", "data-tissue") == tissue)
        settled(page)
        for panel in page.query_selector_all("#side .panel"):
            edge = panel.bounding_box()
            right = edge["x"] + edge["width"]
            for element in panel.query_selector_all("td, li, div, span, code, b"):
                box = element.bounding_box()
                if box and box["width"]:
                    assert box["x"] + box["width"] <= right + 1, (
                        tissue, element.inner_text()[:60], box["x"] + box["width"], right)
        assert "relaxation is relaxes" in page.inner_text("#defaults")
    assert not errors
