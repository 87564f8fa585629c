"""Bokeh server against Panel for ``isj app``: import time, first render and slider latency.

Run:  .venv/bin/python benchmarks/app_framework.py [--panel-site DIR] [--repeat N]

Each framework serves the same one-slider page (the gap's modulus on a log slider, α and β
of the lumped model in one text) on 127.0.0.1; headless Chromium (/usr/bin/chromium,
through Playwright) opens it and moves the slider with the keyboard. Prints, per framework:
the import time of the framework in a fresh interpreter (best of 3), the time from page load
to the first α shown, and the median and largest time from a key press on the slider to the
updated α text. Panel is not a dependency of isj: give ``--panel-site`` a folder it was
installed in (``pip install --target DIR panel``) to include it.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import time

_BOKEH_APP = """
import math
from bokeh.models import Div, Slider
from bokeh.layouts import column
from bokeh.plotting import curdoc
from isj.lumped.api import LumpedModel
lm = LumpedModel.default()
def text(x):
    r = lm.static(gap_e_pa=10 ** x)
    return f'<span id="alpha">{r.alpha_rad * 1e6:.4f}</span> <span id="beta">{r.beta_rad * 1e6:.4f}</span>'
s = Slider(start=6, end=7.7, step=0.01, value=7, title="log10 gap_e_pa")
d = Div(text=text(7))
s.on_change("value", lambda attr, old, new: setattr(d, "text", text(new)))
curdoc().add_root(column(s, d))
"""

_PANEL_APP = """
import panel as pn
from isj.lumped.api import LumpedModel
lm = LumpedModel.default()
def text(x):
    r = lm.static(gap_e_pa=10 ** x)
    return f'<span id="alpha">{r.alpha_rad * 1e6:.4f}</span> <span id="beta">{r.beta_rad * 1e6:.4f}</span>'
s = pn.widgets.FloatSlider(start=6, end=7.7, step=0.01, value=7, name="log10 gap_e_pa")
d = pn.pane.HTML(text(7))
s.param.watch(lambda e: setattr(d, "object", text(e.new)), "value")
pn.Column(s, d).servable()
"""

#: JavaScript: the text of the element with id ``alpha``, searched through open shadow roots.
FIND_JS = """() => {
  const walk = (root) => {
    const el = root.querySelector('#alpha');
    if (el) return el;
    for (const n of root.querySelectorAll('*')) {
      if (n.shadowRoot) { const f = walk(n.shadowRoot); if (f) return f; }
    }
    return null;
  };
  const el = walk(document);
  return el ? el.textContent : null;
}"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def import_time(stmt: str, env: dict) -> float:
    code = f"import time; t = time.perf_counter(); {stmt}; print(time.perf_counter() - t)"
    runs = [
        float(subprocess.check_output([sys.executable, "-c", code], env=env, text=True)) for _ in range(3)
    ]
    return min(runs)


def measure(kind: str, app_dir: str, env: dict, repeat: int) -> dict:
    port = free_port()
    path = os.path.join(app_dir, f"{kind}_app.py")
    with open(path, "w") as f:
        f.write(_BOKEH_APP if kind == "bokeh" else _PANEL_APP)
    mod = "bokeh" if kind == "bokeh" else "panel"
    cmd = [sys.executable, "-m", mod, "serve", path, "--port", str(port), "--address", "127.0.0.1"]
    cmd += ["--allow-websocket-origin", f"127.0.0.1:{port}"]
    server = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        url = f"http://127.0.0.1:{port}/{kind}_app"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                time.sleep(0.2)
        from playwright.sync_api import sync_playwright

        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path="/usr/bin/chromium", headless=True)
            page = browser.new_page()
            t0 = time.perf_counter()
            page.goto(url)
            page.wait_for_function(FIND_JS, polling="raf", timeout=60_000)
            first = time.perf_counter() - t0
            handle = page.locator(".noUi-handle").first
            handle.focus()
            lat = []
            for i in range(repeat):
                before = page.evaluate(FIND_JS)
                t0 = time.perf_counter()
                page.keyboard.press("ArrowRight" if i % 2 == 0 else "ArrowLeft")
                page.wait_for_function(f"() => ({FIND_JS})() !== {before!r}", polling="raf", timeout=10_000)
                lat.append(time.perf_counter() - t0)
            browser.close()
    finally:
        server.terminate()
        server.wait(10)
    return {"first_render_s": first, "median_s": statistics.median(lat), "max_s": max(lat)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--panel-site", help="folder where panel is installed (pip install --target)")
    ap.add_argument("--repeat", type=int, default=30, help="slider moves per framework (default 30)")
    args = ap.parse_args(argv)
    import tempfile

    kinds = {"bokeh": dict(os.environ)}
    if args.panel_site:
        kinds["panel"] = dict(os.environ, PYTHONPATH=args.panel_site)
    with tempfile.TemporaryDirectory() as tmp:
        for kind, env in kinds.items():
            stmt = "import bokeh.server.server, bokeh.models" if kind == "bokeh" else "import panel"
            t_imp = import_time(stmt, env)
            m = measure(kind, tmp, env, args.repeat)
            print(
                f"{kind:6s} import {t_imp * 1e3:5.0f} ms   "
                f"first render {m['first_render_s'] * 1e3:5.0f} ms   "
                f"slider -> alpha text: median {m['median_s'] * 1e3:4.0f} ms, max {m['max_s'] * 1e3:4.0f} ms "
                f"({args.repeat} moves)"
            )


if __name__ == "__main__":
    main()
