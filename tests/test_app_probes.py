"""``isj app`` probed in headless Chromium (issue 27): bad values in every control, a tab closed
during a long action, and two tabs at once.

Every control of the page (isj/app/server.py) gets bad values: the fourteen typed fields beside
the sliders (five moduli, eight dimensions, the pressure), the sliders themselves (a value past
their range, as a client could send it), the FE mesh resolution, the uncertainty's factor and
sample count, the selects (map axes, the five distributions, reset-to, plot format) and the
joint's buttons. A select or the buttons offer only valid choices in the browser, so their bad
values are set on the page's Bokeh model, which sends them to the server as a click would. Each
bad value must give the one-line message naming the control and its valid range, leave α, β and
β/α as they were, and a valid value set next must update the outputs again. The probes share one
tab, in order, each leaving every control valid (a failed probe can fail the ones after it).

The server runs with private caches (FE results, meshes, surrogates), so that a tab closed
during an FE solve or the surrogate's build can be checked for leftover processes and partial
cache files. Helpers shared with tests/test_app.py are imported from it.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import pytest
from test_app import CHROMIUM, _children, _open, chromium, lumped_solve_json, serving_app, shown

from isj.app import state
from isj.errors import InvalidParameter

pytestmark = pytest.mark.slow  # the app in a browser, FE verify

NUMERIC = (*state.MODULI, *state.GEOMETRY_FIELDS, "pressure_pa")

#: How long a page may take to answer one change on the loaded 2-core machine (ms).
WAIT_MS = 30_000


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """``isj app --no-browser`` at a free port with every cache private; yields (url, process, folder)."""
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (scripts/setup installs Debian's chromium)")
    pytest.importorskip(
        "playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')"
    )
    tmp = tmp_path_factory.mktemp("app_probes")
    env = dict(
        os.environ,
        HOME=str(tmp / "home"),
        ISJ_FE_CACHE_DIR=str(tmp / "fe"),
        ISJ_CACHE_DIR=str(tmp / "cache"),
    )
    with serving_app(env) as (url, proc):
        yield url, proc, tmp


@pytest.fixture(scope="module")
def browser(server):
    with chromium() as b:
        yield b


@pytest.fixture(scope="module")
def page(browser, server):
    """One tab shared by the probes: each probe leaves it with a valid value in every control."""
    p = _open_page(browser, server[0])
    _show_uq(p)
    yield p
    p.close()


# ---- driving the page -------------------------------------------------------------------------

#: Helpers in the page: ``isj.find([css class, type, title])`` one Bokeh model (by a CSS class of
#: ours, or by type and title or button labels); ``isj.span(id)`` the text of the element ``id``
#: in the Div that holds it; ``isj.snap()`` what the probes read; ``isj.fields()`` the typed fields.
_PAGE_JS = """
() => {
  const models = () => {
    const d = Bokeh.documents[0];
    return [...(d.all_models ?? d._all_models.values())];
  };
  const find = ([cls, type, title]) => models().find(m => cls !== null
      ? (m.css_classes ?? []).includes(cls)
      : m.constructor.__name__ === type &&
        (title === null || m.title === title || (m.labels ?? []).join() === title)) ?? null;
  const span = (id) => {
    for (const m of models()) {
      if (m.constructor.__name__ !== "Div" || typeof m.text !== "string") continue;
      if (!m.text.includes(`id='${id}'`) && !m.text.includes(`id="${id}"`)) continue;
      const t = document.createElement("div");
      t.innerHTML = m.text;
      return t.querySelector("#" + id).textContent;
    }
    return null;
  };
  const snap = () => ({message: span("message"), alpha: span("alpha"), beta: span("beta"),
                       ratio: span("ratio"), uq: span("uq"), map: span("map")});
  const fields = () => {
    const out = {};
    for (const m of models())
      for (const c of (m.css_classes ?? []))
        if (c.startsWith("isj-text-")) out[c.slice(9)] = m.value;
    out.joint = find([null, "RadioButtonGroup", "bonded,sliding"]).active;
    return out;
  };
  window.isj = {find, span, snap, fields};
}
"""


def _open_page(browser, url):
    p = _open(browser, url)
    p.evaluate(_PAGE_JS)
    return p


def _show_uq(page) -> None:
    """Show the Uncertainty tab once (the page computes a tab when it is first shown), then the first."""
    _set_model(page, (None, "Tabs", None), "active", 3)
    page.wait_for_function("() => isj.span('uq') !== ''", timeout=WAIT_MS)
    _set_model(page, (None, "Tabs", None), "active", 0)


def _set_model(page, find: tuple, prop: str, value) -> None:
    """Set ``prop`` of the model ``find`` (css class, type, title) in the browser: the server gets it."""
    if isinstance(value, float) and math.isnan(value):  # JSON has no NaN: make it in JavaScript
        page.evaluate("([find, prop]) => { isj.find(find)[prop] = NaN; }", [list(find), prop])
    else:
        page.evaluate("([find, prop, v]) => { isj.find(find)[prop] = v; }", [list(find), prop, value])


def _get_model(page, find: tuple, prop: str):
    return page.evaluate("([find, prop]) => isj.find(find)[prop]", [list(find), prop])


def _type(page, selector: str, text: str) -> None:
    field = page.locator(selector)
    field.fill(text)
    field.press("Enter")


def _snap(page) -> dict:
    return page.evaluate("() => isj.snap()")


def _numbers(page) -> tuple[str, str, str]:
    s = _snap(page)
    return s["alpha"], s["beta"], s["ratio"]


def _wait(page, has: dict | None = None, **want) -> None:
    """Wait (each frame) until the page's texts equal ``want`` and contain ``has``."""
    js = """([want, has]) => { const s = isj.snap();
        return Object.entries(want).every(([k, v]) => s[k] === v)
            && Object.entries(has).every(([k, v]) => s[k] !== null && s[k].includes(v)); }"""
    from playwright.sync_api import TimeoutError

    try:
        page.wait_for_function(js, arg=[want, has or {}], polling="raf", timeout=WAIT_MS)
    except TimeoutError:
        raise AssertionError(f"the page shows {_snap(page)}, not {want} {has or ''}") from None


def _shown_numbers(out: dict) -> dict:
    """α, β (µrad) and β/α of ``out`` (a static_outputs or lumped solve dict) as the page shows them."""
    return dict(
        alpha=shown(out["alpha_rad"] * 1e6),
        beta=shown(out["beta_rad"] * 1e6),
        ratio=shown(out["beta_over_alpha"]),
    )


def _expect_numbers(page, out: dict, **also) -> None:
    """Wait until the page shows α, β and β/α of ``out`` (and the texts ``also``)."""
    want = _shown_numbers(out)
    _wait(page, **want, **also)
    assert page.locator("#alpha").text_content() == want["alpha"]  # drawn, not only received


def _check_one_line(msg: str, *words: str) -> None:
    assert msg and "\n" not in msg and len(msg) < 200, msg
    for w in words:
        assert w in msg, (w, msg)


def _page_design(page) -> state.Design:
    """The page's design: its typed fields, and the joint its buttons show."""
    fields = page.evaluate("() => isj.fields()")
    d = state.Design().replace("joint", state.JOINTS[fields.pop("joint")])
    for k, v in fields.items():
        d = d.replace(k, float(v))
    return d


def _bad_then_valid(page, make_bad, expected: str, make_valid, valid_outputs) -> state.Design:
    """A bad value shows ``expected`` and leaves α, β, β/α; a valid one next updates them.

    ``make_valid()`` sets a valid value and returns the design it makes; ``valid_outputs(design)``
    gives the α, β, β/α the page must show then. Returns that design.
    """
    alpha, beta, ratio = before = _numbers(page)
    make_bad()
    _wait(page, message=expected, alpha=alpha, beta=beta, ratio=ratio)  # the message, numbers as before
    assert page.locator("#message").text_content() == expected  # drawn, not only received
    after = make_valid()
    want = valid_outputs(after)
    assert tuple(_shown_numbers(want).values()) != before  # so that the update shows
    _expect_numbers(page, want, message="")
    return after


# ---- bad values in every numeric field --------------------------------------------------------


def _range(name: str) -> str:
    lo, hi = state.field_specs()[name].valid
    return f"[{lo:g}, {hi:g}]"


def _bad_texts(i: int, name: str) -> list[str]:
    """Values typed into the ``i``-th field, ``name``, that it must refuse.

    Every field gets a word, NaN and an empty field, and two of the other eight kinds (±inf,
    negative, zero, above or below the range, a 400-digit number, 5000 letters), taken in turn
    along the fields so that each kind meets moduli and dimensions.
    """
    lo, hi = state.field_specs()[name].valid
    kinds = [
        "inf",
        f"{-1.5 * lo:g}",  # negative
        f"{hi * 10:g}",  # above the range
        "1" * 400,  # very long: a number too large for a float
        "-inf",
        "0",  # zero: every range is positive
        f"{lo / 10:g}",  # below the range
        "x" * 5000,  # very long, not a number
    ]
    return ["fifty", "nan", "", kinds[(2 * i) % 8], kinds[(2 * i + 3) % 8]]


#: Valid values that change a dimension's limit on another, so that the page must refuse them:
#: a capsule bond longer than its reach, a reach beyond the plate, a pedicle wider than the joint.
INCONSISTENT = [
    ("capsule_bond_m", "5e-05"),
    ("capsule_reach_m", "1e-05"),
    ("plate_thickness_m", "1e-05"),
    ("pedicle_x_m", "0.001"),
    ("pedicle_y_m", "0.0015"),
]

FIELD_CASES = [(k, t) for i, k in enumerate(NUMERIC) for t in _bad_texts(i, k)] + INCONSISTENT


def _expected(design: state.Design, name: str, text: str) -> str:
    """The message of a refused value: parse_value's, or the design's naming the field typed."""
    try:
        v = state.parse_value(name, text)
    except InvalidParameter as exc:
        return str(exc)
    try:
        design.replace(name, v)
    except InvalidParameter as exc:
        return str(exc) if name in str(exc) else f"{name} = {v:.6g}: {exc}"
    raise AssertionError(f"{name} = {text!r} is valid")


def _value(design: state.Design, name: str) -> float:
    return {**design.moduli, **design.dims, "pressure_pa": design.pressure_pa}[name]


def _other_valid(design: state.Design, name: str) -> str:
    """A valid value of ``name`` other than the design's: the default, or 5 % above it."""
    default = _value(state.Design(), name)
    return f"{default:.6g}" if _value(design, name) != default else f"{default * 1.05:.6g}"


@pytest.mark.parametrize("name, text", FIELD_CASES, ids=[f"{k}-{t[:12]}" for k, t in FIELD_CASES])
def test_bad_typed_value(page, name, text):
    design = _page_design(page)
    expected = _expected(design, name, text)
    words = [name] if (name, text) in INCONSISTENT else [name, _range(name)]
    _check_one_line(expected, *words)
    selector = f".isj-text-{name} input"

    def valid():
        v = _other_valid(design, name)
        _type(page, selector, v)
        return design.replace(name, float(v))

    after = _bad_then_valid(page, lambda: _type(page, selector, text), expected, valid, state.static_outputs)
    assert _page_design(page) == after


# ---- the sliders: a value past their range, as a client could send it ---------------------------


def _slider_pos(name: str, value: float) -> float:
    spec = state.field_specs()[name]
    return math.log10(value) if spec.log else (value * 1e6 if spec.unit == "m" else value)


def _slider_value(name: str, pos: float) -> str:
    """The value (as the page formats it) of slider position ``pos``."""
    spec = state.field_specs()[name]
    if spec.log:
        return "inf" if pos > 308 else f"{10**pos:.6g}"
    return f"{pos * 1e-6 if spec.unit == 'm' else pos:.6g}"


#: Past the top of the physical range for every slider; NaN for one of each kind.
SLIDER_CASES = [(k, "above") for k in NUMERIC] + [(k, "nan") for k in ("gap_e_pa", "plate_thickness_m")]


@pytest.mark.parametrize("name, kind", SLIDER_CASES)
def test_bad_slider_value(page, name, kind):
    hi = state.field_specs()[name].valid[1]
    pos = math.nan if kind == "nan" else _slider_pos(name, hi) + 1000
    design = _page_design(page)
    expected = _expected(design, name, _slider_value(name, pos))
    _check_one_line(expected, name, _range(name))
    find = (f"isj-slider-{name}", None, None)

    def valid():
        p = _slider_pos(name, float(_other_valid(design, name)))
        _set_model(page, find, "value", p)
        return design.replace(name, float(_slider_value(name, p)))

    after = _bad_then_valid(
        page, lambda: _set_model(page, find, "value", pos), expected, valid, state.static_outputs
    )
    assert _page_design(page) == after  # the text field follows the slider


# ---- the other controls ----------------------------------------------------------------------

FE_RES_BAD = ["fine", "nan", "-1", "0.05", "99", "", "9" * 400]


@pytest.mark.parametrize("text", FE_RES_BAD, ids=[t[:12] for t in FE_RES_BAD])
def test_bad_fe_resolution(page, server, text):
    """Refused as typed, and by Verify: no FE job starts; a valid one goes into the case file."""
    from playwright.sync_api import expect

    before = _numbers(page)
    new = "0.5" if _get_model(page, ("isj-fe-res", None, None), "value") != "0.5" else "0.75"
    _type(page, ".isj-fe-res input", text)
    _wait(page, has=dict(message="FE mesh resolution"))
    _check_one_line(_snap(page)["message"], "FE mesh resolution", "[0.1, 8]", text[:40])
    page.locator(".isj-verify button").click()
    _type(page, ".isj-fe-res input", new)  # handled after the click: when its message goes, both are
    _wait(page, message="")
    assert page.locator("#fe").text_content() == "" and page.locator("#fe-progress").count() == 0
    assert _children(server[1].pid) == []
    assert _numbers(page) == before
    _set_model(page, (None, "Tabs", None), "active", 4)  # the Export tab: the case file
    expect(page.locator("#case")).to_contain_text(f"resolution = {float(new)!r}", timeout=WAIT_MS)
    _set_model(page, (None, "Tabs", None), "active", 0)


def _uq_text(design: state.Design, kinds: dict, factor: float, samples: int) -> str:
    """What the uncertainty view shows for these distributions (the page's format)."""
    u = state.uncertainty(design, kinds, factor, samples)
    lo, hi = u["p_interval"]
    return (
        f"P(β/α > 1) = {u['p_gt_1']:.4f} (95 % interval {lo:.4f}–{hi:.4f}, "
        f"{u['samples']} draws, lumped model)"
    )


def _uq_state(page) -> tuple[dict, float, int]:
    kinds = {k: _get_model(page, (f"isj-uq-{k}", None, None), "value") for k in state.MODULI}
    factor = float(_get_model(page, (None, "TextInput", "lognormal factor"), "value"))
    samples = int(_get_model(page, (None, "TextInput", "samples"), "value"))
    return kinds, factor, samples


def _settle_uq(page, design: state.Design) -> None:
    """Wait until the uncertainty view shows what its controls ask for (state.uncertainty's numbers)."""
    _wait(page, uq=_uq_text(design, *_uq_state(page)))


UQ_CASES = [("lognormal factor", t) for t in ["wide", "nan", "inf", "1", "100", ""]] + [
    ("samples", t) for t in ["many", "-5", "999", "200001", "1e4", "9" * 400]
]


@pytest.mark.parametrize("title, text", UQ_CASES, ids=[f"{a.split()[-1]}-{t[:12]}" for a, t in UQ_CASES])
def test_bad_uncertainty_input(page, title, text):
    find = (None, "TextInput", title)
    design = _page_design(page)
    kinds, factor, samples = _uq_state(page)
    if title == "samples":
        words = ["samples", "[1000, 200000]"]
        new = "5000" if samples != 5000 else "20000"
    else:
        words = ["factor", f"(1, {math.exp(3):.4g}]"]
        new = "3" if factor != 3 else "2"
        _set_model(page, ("isj-uq-gap_e_pa", None, None), "value", "lognormal")  # so the factor counts
    _settle_uq(page, design)
    before = _snap(page)
    _set_model(page, find, "value", text)
    _wait(page, has=dict(message=words[0]))
    now = _snap(page)
    _check_one_line(now["message"], *words)
    assert (now["uq"], _numbers(page)) == (before["uq"], (before["alpha"], before["beta"], before["ratio"]))
    _set_model(page, find, "value", new)
    _wait(page, message="")
    _settle_uq(page, design)
    assert _snap(page)["uq"] != before["uq"]  # the new factor or sample size shows
    _set_model(page, ("isj-uq-gap_e_pa", None, None), "value", "loguniform")
    _settle_uq(page, design)


#: Values a select does not offer (set on its model); map x = map y is a choice the page offers.
SELECT_CASES = (
    [(f"isj-uq-{k}", ("bogus", "")[i % 2]) for i, k in enumerate(state.MODULI)]
    + [("isj-map-x", v) for v in ("bogus", "", "gap_e_pa")]  # gap_e_pa: the same as map y
    + [("isj-map-y", v) for v in ("bogus", "pedicle_e_pa")]
)


@pytest.mark.parametrize("cls, value", SELECT_CASES)
def test_bad_select(page, cls, value):
    find = (cls, None, None)
    old = _get_model(page, find, "value")
    design = _page_design(page)
    if cls.startswith("isj-uq-"):
        _settle_uq(page, design)
    before = _snap(page)
    _set_model(page, find, "value", value)
    if cls.startswith("isj-uq-"):
        k = cls.removeprefix("isj-uq-")
        words = [f"{k} distribution = {value!r}", ", ".join(state.UQ_KINDS)]
    elif value in state.MODULI:
        words = [f"map axes: x and y are both {value}", "two different moduli"]
    else:
        x, y = (_get_model(page, (f"isj-map-{a}", None, None), "value") for a in "xy")
        words = [f"map axes = {x}, {y}", ", ".join(state.MODULI)]
    _wait(page, has=dict(message=words[0]))
    now = _snap(page)
    _check_one_line(now["message"], *words)
    assert {k: now[k] for k in ("alpha", "beta", "ratio", "uq")} == {
        k: before[k] for k in ("alpha", "beta", "ratio", "uq")
    }
    if cls.startswith("isj-uq-"):
        _set_model(page, find, "value", "lognormal")
        _wait(page, message="")
        _settle_uq(page, design)
    else:
        x = _get_model(page, ("isj-map-x", None, None), "value")
        y = _get_model(page, ("isj-map-y", None, None), "value")
        x, y = ("capsule_e_pa", y) if cls == "isj-map-x" else (x, "capsule_e_pa")
        _set_model(page, find, "value", "capsule_e_pa")
        z = np.log10(state.ratio_map(design, x, y)["ratio"])  # as the page computes the range
        ratio = state.static_outputs(design)["beta_over_alpha"]
        _wait(
            page,
            message="",
            map=f"β/α from {10 ** z.min():.3g} to {10 ** z.max():.3g} over {x} × {y}; "
            f"× marks the design (β/α = {ratio:.4g})",
        )
    _set_model(page, find, "value", old)
    if cls.startswith("isj-uq-"):
        _settle_uq(page, design)


@pytest.mark.parametrize("value", ["bogus", ""])
def test_bad_reset_case(page, value):
    find = (None, "Select", "reset to")
    design = _page_design(page)
    before = _numbers(page)
    _set_model(page, find, "value", value)
    page.get_by_role("button", name="Reset", exact=True).click()
    _wait(page, has=dict(message=f"case = {value!r}"))
    _check_one_line(_snap(page)["message"], "defaults", "j5")
    assert _numbers(page) == before and _page_design(page) == design
    target = "j5" if design != state.Design.case("j5") else "defaults"
    _set_model(page, find, "value", target)
    page.get_by_role("button", name="Reset", exact=True).click()
    _wait(page, message="")
    _expect_numbers(page, state.static_outputs(state.Design.case(target)))
    assert _page_design(page) == state.Design.case(target)


@pytest.mark.parametrize("value", ["bogus", "pdf"])
def test_bad_plot_format(page, value):
    find = (None, "Select", "plots save as")
    before = _numbers(page)
    _set_model(page, find, "value", value)
    _wait(page, message=f"plots save as = {value!r}: must be png or svg")
    assert _numbers(page) == before
    _set_model(page, find, "value", "svg")
    _wait(page, message="")
    page.wait_for_function("() => isj.find([null, 'Figure', null]).output_backend === 'svg'", timeout=WAIT_MS)
    _set_model(page, find, "value", "png")
    page.wait_for_function(
        "() => isj.find([null, 'Figure', null]).output_backend === 'canvas'", timeout=WAIT_MS
    )


@pytest.mark.parametrize("active", [2, -1, None])
def test_bad_joint(page, active):
    find = (None, "RadioButtonGroup", "bonded,sliding")
    design = _page_design(page)
    assert design.joint == "bonded"

    def valid():
        _set_model(page, find, "active", 1)
        return design.replace("joint", "sliding")

    _bad_then_valid(
        page,
        lambda: _set_model(page, find, "active", active),
        f"joint = {active}: must be 0 (bonded) or 1 (sliding)",
        valid,
        state.static_outputs,
    )
    _set_model(page, find, "active", 0)
    _expect_numbers(page, state.static_outputs(design))


# ---- a tab closed during a long action ---------------------------------------------------------


def _leftovers(folder: Path) -> list[str]:
    """Partial or temporary entries: ``*.partial``, ``*.tmp``, ``*.old``, atomic writes' ``.name.*``."""
    out = []
    for p in folder.rglob("*"):
        n = p.name
        if n.endswith((".partial", ".tmp", ".old")) or (n.startswith(".") and n.count(".") >= 2):
            out.append(str(p.relative_to(folder)))
    return sorted(out)


def test_closed_tabs_during_fe_and_surrogate_build(browser, server):
    """Two tabs closed mid-job (FE solve, surrogate build): both jobs end, a third tab keeps serving."""
    url, proc, tmp = server
    keep = _open_page(browser, url)
    fe_tab, rom_tab = _open_page(browser, url), _open_page(browser, url)
    _type(fe_tab, ".isj-fe-res input", "2")  # a fine mesh: minutes
    fe_tab.locator(".isj-verify button").click()
    fe_tab.locator("#fe-progress").wait_for(timeout=WAIT_MS)
    rom_tab.get_by_role("button", name="Build the surrogate").click()
    rom_tab.locator("#surrogate-progress").wait_for(timeout=WAIT_MS)
    assert len(_children(proc.pid)) == 2
    fe_tab.close()
    rom_tab.close()
    # the server answers the third tab while it ends the jobs
    _type(keep, ".isj-text-gap_e_pa input", "8e6")
    _expect_numbers(keep, lumped_solve_json(_page_design(keep)))
    deadline = time.monotonic() + 30
    while _children(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.25)
    assert _children(proc.pid) == []
    assert _leftovers(tmp) == []
    for lock in tmp.rglob("*.lock"):  # the surrogate build's lock file stays; no one may hold it
        fd = os.open(lock, os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # BlockingIOError if still held
        finally:
            os.close(fd)
    _type(keep, ".isj-text-capsule_e_pa input", "4e7")
    _expect_numbers(keep, lumped_solve_json(_page_design(keep)))
    assert _snap(keep)["message"] == ""
    assert proc.poll() is None
    keep.close()


# ---- two tabs at once ------------------------------------------------------------------------


def test_two_tabs_at_once_keep_their_own_designs_and_results(browser, server):
    """One tab verifies with FE while the other changes its design, joint and uncertainty."""
    url, proc, tmp = server
    a, b = _open_page(browser, url), _open_page(browser, url)
    _show_uq(a)
    _type(a, ".isj-text-gap_e_pa input", "5e6")
    _type(a, ".isj-fe-res input", "0.5")
    _expect_numbers(a, state.static_outputs(state.Design().replace("gap_e_pa", 5e6)))
    a.locator(".isj-verify button").click()
    a.locator("#fe-progress").wait_for(timeout=WAIT_MS)
    # while A's FE job runs: B types a modulus, takes the sliding joint and a bigger sample
    _type(b, ".isj-text-pedicle_e_pa input", "2e9")
    b.get_by_role("button", name="sliding", exact=True).click()
    _set_model(b, (None, "TextInput", "samples"), "value", "50000")
    _wait(b, has=dict(uq="50000 draws"))
    db = _page_design(b)
    assert db == state.Design().replace("pedicle_e_pa", 2e9).replace("joint", "sliding")
    _expect_numbers(b, lumped_solve_json(db))

    a.locator("#fe-alpha").wait_for(timeout=180_000)
    da = _page_design(a)
    assert da == state.Design().replace("gap_e_pa", 5e6)
    lum = lumped_solve_json(da)
    _expect_numbers(a, lum)
    # FE of A's design: the README's isj.PedicleJointModel(order=2, resolution=0.5) at gap 5 MPa
    assert a.locator("#fe-alpha").text_content() == "2.359"
    assert a.locator("#fe-beta").text_content() == "10.66"
    (record,) = [json.loads(p.read_text()) for p in (tmp / "fe").rglob("*.json")]
    fe = record["result"]
    err_a, err_b = lum["alpha_rad"] / fe["alpha_rad"] - 1, lum["beta_rad"] / fe["beta_rad"] - 1
    fe_text = a.locator("#fe").text_content()
    assert f"lumped − FE: α {100 * err_a:+.2f} %, β {100 * err_b:+.2f} %" in fe_text
    assert "for the design when Verify was pressed" not in fe_text
    # nothing of A reached B, nor of B reached A
    assert b.locator("#fe").text_content() == "" and b.locator("#fe-alpha").count() == 0
    assert _page_design(b) == db
    _expect_numbers(b, lumped_solve_json(db))
    assert "20000 draws" in _snap(a)["uq"] and "50000 draws" in _snap(b)["uq"]
    assert _snap(a)["message"] == _snap(b)["message"] == ""
    a.close()
    b.close()
    assert proc.poll() is None
