"""`certiloop gate --html`: one self-contained page. Its structure is checked with the standard
library's HTML parser; its behaviour (no console error, a collapsed branch opens on click, the
search box filters) in a real headless Chromium driven by Selenium."""

import json
import shutil
from fractions import Fraction
from html.parser import HTMLParser
from pathlib import Path

import pytest

from certiloop.api.gate_run import GateEntry
from certiloop.cli import main
from certiloop.cli.gate_html import html_report


def entry(model, expected, verdict, obligations, **more):
    data = {"model": model, "expected": expected, "verdict": verdict, "seconds": 0.5,
            "obligations": obligations, "reason": "", "counterexample": None, "replay": None,
            "falsify": {"verdict": "no counterexample", "examples": 300}, "kernel": None,
            "nonblocking": None, "cross_check": None, "inconsistent": False,
            "checked": f"accepted: {model}" if verdict == "proved" else None}
    data.update(more)
    return GateEntry.from_json(data)


def ob(i, path, verdict="proved", **more):
    return {"id": f"o{i}", "path": path, "verdict": verdict, "seconds": 0.01 * i, "backend": "z3",
            "kind": "safety", "reason": "", "counterexample": None, "check": "", **more}


RUN = {"initial": {"h": "0", "v": "0", "H": "0"}, "violated": "h <= H is false at the end",
       "check": "exact rationals",
       "trace": [{"path": "loop iteration 1 / climb", "what": "a := A",
                  "state": {"h": "0", "v": "0", "a": "1"}},
                 {"path": "loop iteration 1", "what": "follow the ODE for 1 s",
                  "state": {"h": "1/2", "v": "1", "a": "1"}}]}

ENTRIES = [
    entry("drone.altitude_limiter", "proved", "proved",
          [ob(1, "loop init / invariant holds initially"), ob(2, "loop step / climb / ODE solve / preserved"),
           ob(3, "loop step / brake / ODE solve / preserved")]),
    entry("drone.no_reaction_time", "refuted", "refuted",
          [ob(1, "loop init / invariant holds initially"),
           ob(2, "loop step / climb / ODE solve / preserved", "refuted", rule="loop-invariant",
              counterexample={"h": "0", "v": "0"}, check="exact rationals")],
          counterexample=RUN, replay={"violated": True, "message": ""},
          falsify={"verdict": "refuted", "examples": 116, "violated": "h <= H (margin -459)"}),
    entry("conveyor.speed", "proved", "unknown",
          [ob(1, "loop step / fast / ODE solve / preserved", "unknown",
              reason="z3 gave up (resource limit)")],
          reason="1 obligation unknown: z3 gave up (resource limit)"),
]


class Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.stack, self.tags, self.external, self.polylines = [], [], [], []
        self.voids = {"meta", "input", "br", "img", "link", "circle", "line", "hr", "polyline"}

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.append((tag, attrs))
        for key in ("src", "href"):
            if attrs.get(key) and not attrs[key].startswith("#"):
                self.external.append(attrs[key])
        if tag == "polyline":
            self.polylines.append(attrs["points"])
        if tag not in self.voids:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if tag in self.voids:
            return
        assert self.stack and self.stack[-1] == tag, f"</{tag}> closes <{self.stack[-1:]}>"
        self.stack.pop()


def parsed(page: str) -> Collect:
    doc = Collect()
    doc.feed(page)
    doc.close()
    assert doc.stack == ["html"] or doc.stack == [], doc.stack  # every element closed
    return doc


def test_the_page_is_self_contained_and_well_nested():
    page = html_report(ENTRIES)
    doc = parsed(page)
    assert doc.external == []  # no link, script or image fetched from anywhere
    assert not any(tag in ("link", "img", "iframe") for tag, _ in doc.tags)
    assert not any(tag == "script" and "src" in attrs for tag, attrs in doc.tags)
    for name in ("drone.altitude_limiter", "drone.no_reaction_time", "conveyor.speed"):
        assert page.count(name) >= 2  # in the summary table and its own section


def test_every_model_and_obligation_is_shown_with_its_verdict_expectation_and_reason():
    page = html_report(ENTRIES)
    models = [a for tag, a in parsed(page).tags if tag == "details" and "model" in a.get("class", "")]
    assert [m["id"] for m in models] == ["m0", "m1", "m2"]
    assert "open" not in models[0] and "open" in models[2]  # a failure starts open
    assert "z3 gave up (resource limit)" in page  # the unknown's explanation
    assert "rule failed" in page and "strengthen loop(..., invariant=J)" in page  # the rule's hint
    obligations = [a for tag, a in parsed(page).tags if tag == "div" and a.get("class") == "ob"]
    assert len(obligations) == 6
    assert "2 passed" not in page and "1 model(s) failed" in page


def test_the_counterexample_is_plotted_where_its_values_are():
    page = html_report(ENTRIES[1:2])
    doc = parsed(page)
    # h: 0, 0, 1/2 and v: 0, 0, 1 change along the run; a (unset at the start) and H do not plot
    assert len(doc.polylines) == 2
    for points in doc.polylines:
        ys = [float(p.split(",")[1]) for p in points.split()]
        # values 0, 0, then 1/2 (h) or 1 (v), each chart scaled to its own range: SVG's y grows
        # downwards, so the last point is the top of the plot area and the first two its bottom
        assert len(ys) == 3 and ys[0] == ys[1] == 104.0 and ys[2] == 12.0


def test_an_interrupted_gate_says_so():
    page = html_report(ENTRIES[:1], selected=3)
    assert "interrupted: a partial report of the 1 of 3 models finished" in page


def test_gate_writes_the_html_report(tmp_path, capsys, monkeypatch):
    """A real gate over `certiloop init`'s two drone models: the refuted one's run is plotted."""
    monkeypatch.chdir(tmp_path)
    assert main(["init"]) == 0
    assert main(["gate", "--no-cache", "--jobs", "1", "--falsify-examples", "50", "--html", "gate.html",
                 "--json", "gate.json", "-q"]) == 0
    page = (tmp_path / "gate.html").read_text(encoding="utf-8")
    doc = parsed(page)
    assert doc.external == [] and "drone.altitude_limiter" in page and "drone.no_reaction_time" in page
    report = json.loads((tmp_path / "gate.json").read_text())
    run = next(e["counterexample"] for e in report if e["counterexample"])
    end = run["trace"][-1]["state"]
    assert Fraction(end["h"]) > Fraction(end["H"])  # the run the page plots does pass the ceiling
    assert doc.polylines  # ... and it is plotted


def test_a_missing_html_folder_is_bad_input(tmp_path, capsys):
    assert main(["gate", "sbs.ctrl1", "--html", str(tmp_path / "no" / "gate.html")]) == 2
    assert "--html" in capsys.readouterr().err


def chromium():
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not (binary and driver):
        pytest.skip("Chromium and its driver are not installed (apt-get install chromium chromium-driver)")
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed (the test extra)")
    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--window-size=1200,900"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    from selenium.webdriver.chrome.service import Service

    return webdriver.Chrome(options=options, service=Service(driver))


def test_the_report_in_a_headless_browser(tmp_path):
    from selenium.webdriver.common.by import By

    page = tmp_path / "gate.html"
    page.write_text(html_report(ENTRIES), encoding="utf-8")
    browser = chromium()
    try:
        browser.get(page.as_uri())
        errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]
        assert errors == []

        proved = browser.find_element(By.ID, "m0")
        assert proved.get_attribute("open") is None
        proved.find_element(By.TAG_NAME, "summary").click()
        assert proved.get_attribute("open") is not None
        branch = proved.find_element(By.CSS_SELECTOR, "details.branch")
        assert not branch.find_element(By.CSS_SELECTOR, ".ob").is_displayed()  # collapsed
        branch.find_element(By.TAG_NAME, "summary").click()
        assert branch.find_element(By.CSS_SELECTOR, ".ob").is_displayed()

        Path(tmp_path / "before.png").write_bytes(browser.get_screenshot_as_png())
        search = browser.find_element(By.ID, "search")
        search.send_keys("no_reaction")
        shown = [m.get_attribute("id") for m in browser.find_elements(By.CSS_SELECTOR, "details.model")
                 if m.is_displayed()]
        assert shown == ["m1"]
        assert browser.find_element(By.ID, "shown").text == "1"
        refuted = browser.find_element(By.ID, "m1")
        assert refuted.get_attribute("open") is None  # its name matched, not an obligation: still closed
        refuted.find_element(By.TAG_NAME, "summary").click()
        assert refuted.get_attribute("open") is not None
        browser.execute_script("arguments[0].scrollIntoView()", refuted.find_element(By.TAG_NAME, "svg"))
        (tmp_path / "counterexample.png").write_bytes(browser.get_screenshot_as_png())
        search.clear()
        search.send_keys("resource limit")  # an obligation's reason: its model, opened
        shown = [m for m in browser.find_elements(By.CSS_SELECTOR, "details.model") if m.is_displayed()]
        assert [m.get_attribute("id") for m in shown] == ["m2"]
        shot = tmp_path / "gate_report.png"
        shot.write_bytes(browser.get_screenshot_as_png())
        print(f"screenshot: {shot}")
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "ERROR")] == []
    finally:
        browser.quit()
