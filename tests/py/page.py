"""Loads the view's page in Debian's chromium through playwright (never a downloaded browser)
and prints what it drew, as JSON. Saves a screenshot.

- `live WAIT_S`: waits until the run is at least LATE_S sim seconds in (through `/state`), then
  opens the page (late) and keeps the trails it had at its first frame, two samples of
  window.viewState WAIT_S apart, then clicks UAV 1 on the map and keeps the state, the legend's
  text, the scale bar's text and width, and UAV 1's panel text.
- `scan ID`: clicks UAV ID's panel, turns the scan toggle on, keeps the state with the scan drawn.
- `seek TICK [ID]`: seeks a replay to TICK and keeps the state, the trails and the seek bar's
  times, the time shown with the cursor over the bar's middle and the legend; with ID, then
  clicks UAV ID on the map and turns the scan toggle on, as for `scan`.

usage: page.py URL SCREENSHOT.png live WAIT_S
       page.py URL SCREENSHOT.png scan UAV_ID
       page.py URL SCREENSHOT.png seek TICK [UAV_ID]
"""
import json
import sys
import tempfile
import time
import urllib.request

from playwright.sync_api import sync_playwright

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]
STATE = "JSON.parse(JSON.stringify(window.viewState))"
# How far into the run the live page is opened [sim s]: late enough for trails to matter.
LATE_S = 5.0


def wait_until_late(url, timeout_s=120):
    """Polls the view's /state until the run's sim time is at least LATE_S."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with urllib.request.urlopen(url + "state", timeout=10) as r:
            frame = json.load(r).get("frame")
        if frame and frame["t"] >= LATE_S:
            return frame["t"]
        time.sleep(0.2)
    raise SystemExit(f"the run never reached {LATE_S} s")


def click_on_map(page, uav):
    """Clicks UAV `uav` where the canvas drew it, waits until it is selected and returns the
    state."""
    box = page.locator("#c").bounding_box()
    dpr = page.evaluate("window.devicePixelRatio || 1")
    u = page.evaluate(f"window.viewState.uavs.find(u => u.id === {uav})")
    page.mouse.click(box["x"] + u["px"] / dpr, box["y"] + u["py"] / dpr)
    page.wait_for_function(f"window.viewState.selected === {uav}", timeout=10000)
    page.wait_for_timeout(300)
    return page.evaluate(STATE)


def show_scan(page, uav, tick=None, on_map=False):
    """Selects UAV `uav` (its panel, or on the map), turns the scan toggle on and waits until its
    scan (of `tick`, if given) is drawn; returns the state."""
    if on_map:
        click_on_map(page, uav)
    else:
        page.click(f".uav[data-id='{uav}']")
    page.check("#scan")
    cond = f"window.viewState.scan && window.viewState.scan.id === {uav} && window.viewState.scan.hits.length > 0"
    if tick is not None:
        cond += f" && window.viewState.scan.tick === {tick}"
    page.wait_for_function(cond, timeout=30000)
    return page.evaluate(STATE)


def live(page, wait_s):
    out = {"first": page.evaluate(STATE), "first_trails": page.evaluate("window.firstTrails")}
    page.wait_for_timeout(wait_s * 1000)
    out["second"] = page.evaluate(STATE)
    out["selected"] = click_on_map(page, 1)
    out["legend"] = page.inner_text("#legend")
    out["scale_text"] = page.inner_text("#scaletext")
    out["scale_css_px"] = page.locator("#scalebar").bounding_box()["width"]
    out["dpr"] = page.evaluate("window.devicePixelRatio || 1")
    out["panel"] = page.inner_text(".uav[data-id='1']")
    out["panel_selected"] = page.get_attribute(".uav.sel", "data-id")
    return out


def seek(page, tick, uav):
    page.wait_for_function("document.getElementById('controls').style.display === 'block'", timeout=30000)
    page.evaluate(f"window.seekTo({tick})")
    page.wait_for_function(f"window.viewState.tick === {tick}", timeout=30000)
    page.wait_for_timeout(300)
    out = {"seek": page.evaluate(STATE), "trails": page.evaluate("window.trailPoints()")}
    out["seek_time"] = page.inner_text("#seektime")
    out["seek_start"] = page.inner_text("#seekstart")
    out["seek_end"] = page.inner_text("#seekend")
    box = page.locator("#seek").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.wait_for_function("document.getElementById('seekhover').style.display === 'block'", timeout=10000)
    out["seek_hover"] = page.inner_text("#seekhover")
    out["legend"] = page.inner_text("#legend")
    if uav is not None:
        out["scan"] = show_scan(page, uav, tick, on_map=True)
        out["panel_selected"] = page.get_attribute(".uav.sel", "data-id")
    return out


def main():
    url, shot, mode, arg = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
    if mode == "live":
        wait_until_late(url)
    with tempfile.TemporaryDirectory() as profile, sync_playwright() as p:
        browser = p.chromium.launch_persistent_context(
            profile, executable_path="/usr/bin/chromium", headless=True, args=ARGS, viewport={"width": 1200, "height": 800})
        page = browser.new_page()
        page.goto(url)
        page.wait_for_function("window.viewState && window.viewState.uavs.length > 0", timeout=60000)
        if mode == "live":
            out = live(page, float(arg))
        elif mode == "scan":
            out = {"scan": show_scan(page, int(arg))}
        else:
            out = seek(page, int(arg), int(sys.argv[5]) if len(sys.argv) > 5 else None)
        out["title"] = page.title()
        out["clock"] = page.inner_text("#clock")
        out["panels"] = page.locator(".uav").count()
        page.screenshot(path=shot)
        browser.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
