"""Latency of ``isj app`` measured in the browser, per kind of update (target: slider ≤ 150 ms).

Run:  .venv/bin/python benchmarks/app_latency.py [--repeat N] [--resolution R]

Starts ``isj app --no-browser`` on 127.0.0.1 at a free port (with a fresh FE cache and home in a
temporary folder), opens it in headless Chromium (/usr/bin/chromium, through Playwright) and
times, from the browser's side, each kind of update from the input event to the page showing
its result:

- slider: a key press on the gap modulus's slider until the updated α text, and until the
  page's update counter, written after every output (numbers, marks, chain Bode plot, ear
  H_V, map, uncertainty, export), shows the change;
- map: a new x axis chosen for the β/α map until its summary text changes;
- uncertainty: one modulus's distribution changed until P(β/α > 1) is rewritten;
- FE verify: the Verify button until the FE α shows, on a P2 mesh at ``--resolution``
  (default 0.35, the tests' coarse mesh): first the solve, then again from the FE cache.

The page is checked at every animation frame (``wait_for_function(..., polling="raf")``), so
times include up to one frame, and Playwright's round trip to the browser. Prints the median,
90th percentile and largest time of each.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time

CHROMIUM = "/usr/bin/chromium"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _summary(name: str, times: list[float]) -> str:
    t = sorted(times)
    p90 = t[min(len(t) - 1, int(round(0.9 * (len(t) - 1))))]
    return (
        f"{name:34s} median {statistics.median(t) * 1e3:7.0f} ms   p90 {p90 * 1e3:7.0f} ms   "
        f"max {t[-1] * 1e3:7.0f} ms   ({len(t)} updates)"
    )


#: JavaScript: the text of the element with id ``key``, searched through Bokeh's open shadow roots.
_TEXT_JS = """key => {
  const walk = (root) => {
    const el = root.querySelector('#' + key);
    if (el) return el;
    for (const n of root.querySelectorAll('*')) {
      if (n.shadowRoot) { const f = walk(n.shadowRoot); if (f) return f; }
    }
    return null;
  };
  const el = walk(document);
  return el ? el.textContent : null;
}"""


def _text(page, key: str):
    return page.evaluate(_TEXT_JS, key)


def _wait_change(page, key: str, before, timeout_ms: float = 30_000) -> None:
    """Wait, checking at every animation frame, until the text of ``#key`` differs from ``before``."""
    page.wait_for_function(
        f"([key, before]) => ({_TEXT_JS})(key) !== before",
        arg=[key, before],
        polling="raf",
        timeout=timeout_ms,
    )


def run(repeat: int, resolution: float) -> None:
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        port = _free_port()
        env = dict(os.environ, HOME=os.path.join(tmp, "home"), ISJ_FE_CACHE_DIR=os.path.join(tmp, "fe"))
        server = subprocess.Popen(
            [sys.executable, "-m", "isj", "app", "--no-browser", "--port", str(port)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        try:
            server.stdout.readline()  # "isj app: serving on ..."
            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True)
                page = browser.new_page(viewport={"width": 1400, "height": 1200})
                t0 = time.perf_counter()
                page.goto(f"http://127.0.0.1:{port}/")
                page.locator("#alpha").wait_for(timeout=120_000)
                print(f"{'first render (server warm-up included)':34s} {time.perf_counter() - t0:7.2f} s")
                # a second tab: the first render of a warm server
                other = browser.new_page(viewport={"width": 1400, "height": 1200})
                t0 = time.perf_counter()
                other.goto(f"http://127.0.0.1:{port}/")
                other.locator("#alpha").wait_for(timeout=120_000)
                print(f"{'first render (warm server)':34s} {(time.perf_counter() - t0) * 1e3:7.0f} ms")
                other.close()

                to_alpha, to_all = [], []
                handle = page.locator(".isj-slider-gap_e_pa .noUi-handle")
                handle.focus()
                for i in range(repeat):
                    stamp, alpha = _text(page, "stamp"), _text(page, "alpha")
                    t0 = time.perf_counter()
                    page.keyboard.press("ArrowRight" if i % 2 == 0 else "ArrowLeft")
                    _wait_change(page, "alpha", alpha)
                    to_alpha.append(time.perf_counter() - t0)
                    _wait_change(page, "stamp", stamp)
                    to_all.append(time.perf_counter() - t0)
                print(_summary("slider -> alpha text", to_alpha))
                print(_summary("slider -> every output", to_all))

                page.get_by_text("Map", exact=True).click()
                page.locator("#map").wait_for()
                times = []
                for i in range(repeat):
                    before = _text(page, "map")
                    t0 = time.perf_counter()
                    page.locator(".isj-map-x select").select_option(
                        "capsule_e_pa" if i % 2 == 0 else "pedicle_e_pa"
                    )
                    _wait_change(page, "map", before)
                    times.append(time.perf_counter() - t0)
                print(_summary("map axis -> map", times))

                page.get_by_text("Uncertainty", exact=True).click()
                page.locator("#uq").wait_for()
                times = []
                for i in range(repeat):
                    before = _text(page, "uq")
                    t0 = time.perf_counter()
                    page.locator(".isj-uq-gap_e_pa select").select_option(
                        "fixed" if i % 2 == 0 else "loguniform"
                    )
                    _wait_change(page, "uq", before)
                    times.append(time.perf_counter() - t0)
                print(_summary("distribution -> P(beta/alpha > 1)", times))

                res = page.locator(".isj-fe-res input")
                res.fill(f"{resolution:g}")
                res.press("Enter")
                for label in ("FE verify (solve)", "FE verify (from the FE cache)"):
                    t0 = time.perf_counter()
                    page.locator(".isj-verify button").click()
                    page.locator("#fe-progress").wait_for(timeout=30_000)
                    page.locator("#fe-alpha").wait_for(timeout=600_000)
                    print(f"{label:34s} {time.perf_counter() - t0:7.2f} s (P2, resolution {resolution:g})")
                browser.close()
        finally:
            server.terminate()
            server.wait(20)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=40, help="updates per kind (default 40)")
    ap.add_argument(
        "--resolution", type=float, default=0.35, help="FE mesh resolution for Verify (default 0.35)"
    )
    args = ap.parse_args(argv)
    if not os.path.exists(CHROMIUM):
        sys.exit(f"app_latency: no Chromium at {CHROMIUM}; apt-get install chromium")
    run(args.repeat, args.resolution)


if __name__ == "__main__":
    main()
