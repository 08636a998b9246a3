"""Loads the view's page in Debian's chromium through playwright (never a downloaded browser)
and prints what it drew, as JSON: for `live`, two samples of window.viewState some seconds
apart; for `seek TICK`, the state after seeking a replay to TICK; for `scan ID` (and `seek TICK
ID`), also the state once UAV ID's panel is clicked and the scan toggle turned on, with the scan
drawn. Saves a screenshot.

usage: page.py URL SCREENSHOT.png live WAIT_S
       page.py URL SCREENSHOT.png scan UAV_ID
       page.py URL SCREENSHOT.png seek TICK [UAV_ID]
"""
import json
import sys
import tempfile

from playwright.sync_api import sync_playwright

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]


def show_scan(page, uav, tick=None):
    """Selects UAV `uav`, turns the scan toggle on and waits until its scan (of `tick`, if
    given) is drawn; returns the state."""
    page.click(f".uav[data-id='{uav}']")
    page.check("#scan")
    cond = f"window.viewState.scan && window.viewState.scan.id === {uav} && window.viewState.scan.hits.length > 0"
    if tick is not None:
        cond += f" && window.viewState.scan.tick === {tick}"
    page.wait_for_function(cond, timeout=30000)
    return page.evaluate("JSON.parse(JSON.stringify(window.viewState))")


def main():
    url, shot, mode, arg = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
    out = {}
    with tempfile.TemporaryDirectory() as profile, sync_playwright() as p:
        browser = p.chromium.launch_persistent_context(
            profile, executable_path="/usr/bin/chromium", headless=True, args=ARGS, viewport={"width": 1200, "height": 800})
        page = browser.new_page()
        page.goto(url)
        page.wait_for_function("window.viewState && window.viewState.uavs.length > 0", timeout=60000)
        state = "JSON.parse(JSON.stringify(window.viewState))"
        if mode == "live":
            out["first"] = page.evaluate(state)
            page.wait_for_timeout(float(arg) * 1000)
            out["second"] = page.evaluate(state)
        elif mode == "scan":
            out["scan"] = show_scan(page, int(arg))
        else:
            tick = int(arg)
            page.wait_for_function("document.getElementById('controls').style.display === 'block'", timeout=30000)
            page.evaluate(f"window.seekTo({tick})")
            page.wait_for_function(f"window.viewState.tick === {tick}", timeout=30000)
            page.wait_for_timeout(300)
            out["seek"] = page.evaluate(state)
            if len(sys.argv) > 5:
                out["scan"] = show_scan(page, int(sys.argv[5]), tick)
        out["title"] = page.title()
        out["clock"] = page.inner_text("#clock")
        out["panels"] = page.locator(".uav").count()
        page.screenshot(path=shot)
        browser.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
