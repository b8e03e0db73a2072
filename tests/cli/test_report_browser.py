"""The study report in a real headless browser (Debian's chromium): it renders, runs its
JavaScript without errors, draws the Plotly figures, and converts K units on request."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest
from study_cases import (
    FAC_PARAMS,
    FACTORIAL,
    fake_case,
    mixed_status_case,
    two_direction_case,
    write_study,
)

from psdesign.study import run_study

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed")
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--virtual-time-budget=5000",
    "--window-size=1400,2400",
]


def _chromium(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([CHROMIUM, *FLAGS, *args], capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("browser")
    p = write_study(
        tmp,
        'design = "latin-hypercube"\nn_samples = 8\nseeds = [1, 2]\n'
        'outputs = ["porosity", "k_x", "k_z"]',
        '"generator.porosity" = {low = 0.7, high = 0.9}\n'
        '"generator.diameter" = {low = 6e-6, high = 9e-6}',
    )
    run_study(p, tmp / "out", workers=0, case_fn=fake_case, progress=False)
    return tmp / "out" / "report.html"


@pytest.fixture(scope="module")
def report_dom(report) -> str:
    """The report's DOM once chromium has run its scripts (one run for the tests that read it)."""
    return _chromium("--dump-dom", report.as_uri()).stdout


def test_report_renders_without_javascript_errors(report, report_dom, tmp_path) -> None:
    dom = report_dom
    assert 'data-psd-ready="1"' in dom  # DOMContentLoaded handler ran to its end
    errors = re.search(r'<div id="psd-js-errors">(.*?)</div>', dom, flags=re.S)
    assert errors is not None and errors.group(1).strip() == ""
    # Plotly drew every figure (its SVG containers exist), incl. Sobol and the surface
    for div in ("psd-sobol", "psd-surface", "psd-main-effects", "psd-interaction"):
        assert re.search(rf'id="{div}"[^>]*class="[^"]*js-plotly-plot', dom), div
    assert dom.count('class="main-svg"') >= 8
    shot = tmp_path / "report.png"
    _chromium(f"--screenshot={shot}", report.as_uri())
    assert shot.is_file() and shot.stat().st_size > 20_000
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


#: Put first in a copy of the report's <head>: the page runs as in a browser without
#: DecompressionStream (Safari 15-16.3, Firefox ESR 102); the constructor is kept aside.
NO_DECOMPRESSION_STREAM = (
    "<script>window.PSD_KEPT_DS = window.DecompressionStream;"
    " delete window.DecompressionStream;</script>"
)
#: Put last in that copy: once the figures are drawn, both ways unpack plotly.js again (the
#: browser's own, put back, and the report's inflater); the body gets their lengths, equality.
BOTH_WAYS = """<script>window.addEventListener('load', function () {
  window.PSD_PLOTLY.then(function () {
    window.DecompressionStream = window.PSD_KEPT_DS;
    var g = window.PSD_GUNZIP, bytes = g.packed();
    return Promise.all([g.native(bytes), g.inflate(bytes)]);
  }).then(function (t) {
    var both = t[0].length + ',' + t[1].length + ',' + (t[0] === t[1]);
    document.body.setAttribute('data-psd-both', both);
  }).catch(function (e) { document.body.setAttribute('data-psd-both', 'error: ' + e); });
});</script>"""


def _without(html: str, head_script: str, body_script: str = "") -> str:
    """The report's page with ``head_script`` run before any of its own scripts."""
    head = '<head><meta charset="utf-8">'
    assert html.count(head) == 1
    return html.replace(head, head + head_script).replace("</body>", body_script + "</body>")


def _plots(dom: str) -> list[str]:
    """The ids of the figures Plotly drew, in page order."""
    return re.findall(r'<div id="([^"]+)" class="[^"]*js-plotly-plot', dom)


def test_a_browser_without_decompression_stream_draws_every_figure(
    report, report_dom, tmp_path
) -> None:
    """Session 44: plotly.js is inlined gzip-compressed (session 43) and main's loader unpacked
    it with DecompressionStream alone; without it (Safari < 16.4, Firefox < 113) the report drew
    no figure. Now the loader runs the inlined inflater (fflate's gunzip) there. Truth: the
    same figures as with the browser's own unpacking (the same plotly SVG roots), the
    inflater's text equal to DecompressionStream's and as long as plotly's own script (UTF-16
    units, as JavaScript counts). On main's loader: no figure drawn, no PSD_GUNZIP."""
    from plotly.offline import get_plotlyjs

    page = tmp_path / "old_browser.html"
    page.write_text(_without(report.read_text(), NO_DECOMPRESSION_STREAM, BOTH_WAYS))
    dom = _chromium("--dump-dom", page.as_uri()).stdout
    errors = re.search(r'<div id="psd-js-errors">(.*?)</div>', dom, flags=re.S)
    assert errors is not None and errors.group(1).strip() == "", errors
    assert 'data-psd-gunzip="inflate"' in dom and 'data-psd-gunzip="native"' in report_dom
    assert len(_plots(report_dom)) >= 4 and _plots(dom) == _plots(report_dom)
    assert dom.count('class="main-svg"') == report_dom.count('class="main-svg"')
    both = re.search(r'data-psd-both="([^"]*)"', dom)
    n = len(get_plotlyjs().encode("utf-16-le")) // 2
    assert both is not None and both.group(1) == f"{n},{n},true", both


def test_a_browser_that_cannot_unpack_says_so_and_shows_tables_and_pictures(
    report, tmp_path
) -> None:
    """A browser with neither DecompressionStream nor typed arrays (the inflater's need) gets
    one line saying why there are no figures; the tables (in the unit asked for) and the
    preview pictures still show."""
    page = tmp_path / "no_unpacking.html"
    hide = "<script>delete window.DecompressionStream; delete window.Uint8Array;</script>"
    page.write_text(_without(report.read_text(), hide))
    dom = _chromium("--dump-dom", page.as_uri() + "#unit=darcy").stdout
    errors = re.search(r'<div id="psd-js-errors">(.*?)</div>', dom, flags=re.S)
    assert errors is not None
    lines = errors.group(1).strip().splitlines()
    assert len(lines) == 1 and "cannot unpack the report's interactive figures" in lines[0]
    assert "tables and pictures still hold every value" in lines[0] and not _plots(dom)
    cells = re.findall(r'<td data-m2="([^"]+)">([^<]*)</td>', dom)
    assert cells
    for m2, shown in cells:  # the unit selector still converts the tables
        assert float(shown) == pytest.approx(float(m2) / 9.869233e-13, rel=1e-3)
    gallery = re.search(r'<div class="psd-gallery" id="psd-thumbs"[^>]*>(.*?)</div>', dom, re.S)
    assert gallery is not None and ' src="data:image/' in gallery.group(1)


# slow: the same darcy conversion of every K cell is asserted by the default
# test_darcy_leaves_log10_k_alone_and_relabels_the_k_headers (and in the page that cannot
# unpack); this one only repeats it on the module's report (one more chromium run)
@pytest.mark.slow
def test_unit_selector_converts_k_to_darcy(report) -> None:
    dom = _chromium("--dump-dom", report.as_uri() + "#unit=darcy").stdout
    cells = re.findall(r'<td data-m2="([^"]+)">([^<]*)</td>', dom)
    assert cells
    for m2, shown in cells:
        assert float(shown) == pytest.approx(float(m2) / 9.869233e-13, rel=1e-3)


def test_flow_field_pictures_load_next_to_the_previews(tmp_path) -> None:
    # both galleries page on load: every picture of their first page gets its src (the flow
    # fields' gallery shared the previews' id and its pictures stayed broken)
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    run_study(p, tmp_path / "out", workers=0, case_fn=mixed_status_case, progress=False)
    dom = _chromium("--dump-dom", (tmp_path / "out" / "report.html").as_uri()).stdout
    for gid, mime in (("psd-thumbs", "jpeg"), ("psd-fields", "png")):  # previews: JPEG (s43)
        gallery = re.search(rf'<div class="psd-gallery" id="{gid}"[^>]*>(.*?)</div>', dom, re.S)
        assert gallery is not None, gid
        imgs = re.findall(r"<img\b[^>]*>", gallery.group(1))
        assert len(imgs) == 8 and all(f' src="data:image/{mime}' in i for i in imgs), gid


#: Written into a copy of the report: the K table's box, its scroll and client widths.
K_TABLE_WIDTHS = """<script>window.addEventListener('load', function () {
  var h = Array.prototype.find.call(document.querySelectorAll('h3'), function (e) {
    return e.textContent.indexOf('Permeability with error bars') === 0; });
  var box = h.nextElementSibling.nextElementSibling;
  document.body.setAttribute('data-kbox', box.scrollWidth + ',' + box.clientWidth);
});</script>"""


@pytest.mark.parametrize("outputs", ['"k_x", "k_z"', '"k_x", "k_y", "k_z"'])
def test_the_k_table_fits_a_1400_px_window_with_two_directions(tmp_path, outputs) -> None:
    """Session 42 saw the K table scroll sideways at 1400 px with two directions; measured
    (session 43, benchmarks/RESULTS.md) 1601 px of table in a 1319 px box with main's 8
    columns (K, status, bc per direction), and the box's own width now. The layout, not the
    pixels: the box's scrollWidth is at most its clientWidth. Review2: three directions (the
    k_tensor's columns, each with the untrustworthy reason) fit too."""
    p = write_study(
        tmp_path,
        f'design = "full-factorial"\nseeds = [1, 2]\noutputs = ["porosity", {outputs}]\n'
        'solver = "voxel"',
        '"generator.porosity" = [0.8, 0.9]',
    )
    run_study(p, tmp_path / "out", workers=0, case_fn=two_direction_case, progress=False)
    scroll, client = _widths(tmp_path / "out" / "report.html", K_TABLE_WIDTHS, "kbox", 1400)
    assert 1000 < client and scroll <= client, (scroll, client)


def _widths(report, script: str, attr: str, window: int) -> tuple[int, int]:
    """The two widths ``script`` (written into a copy of ``report``) sets as ``data-<attr>``
    on the body, in a ``window`` px wide chromium."""
    page = report.parent / "measured.html"
    page.write_text(report.read_text().replace("</body>", script + "</body>"))
    out = subprocess.run(
        [CHROMIUM, *FLAGS[:-1], f"--window-size={window},900", "--dump-dom", page.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
    ).stdout
    widths = re.search(rf'data-{attr}="(\d+),(\d+)"', out)
    assert widths is not None, out[-2000:]
    scroll, client = map(int, widths.groups())
    return scroll, client


#: Written into a copy of the report: the page's scroll and client widths.
PAGE_WIDTHS = """<script>window.addEventListener('load', function () {
  var d = document.documentElement;
  document.body.setAttribute('data-page', d.scrollWidth + ',' + d.clientWidth);
});</script>"""


def test_the_page_does_not_scroll_sideways_in_an_800_px_window(report, tmp_path) -> None:
    """Session 45 looked at the report in an 800 px window: the Study table's one-line cells
    (last run, machine, versions) made the page 1087 px wide in a 785 px one, the values cut
    off at the window's edge. The layout, not the pixels: the page's scrollWidth is at most
    its clientWidth (wide tables scroll inside their own boxes)."""
    copy = tmp_path / "report.html"
    copy.write_text(report.read_text())
    scroll, client = _widths(copy, PAGE_WIDTHS, "page", 800)
    assert 700 < client and scroll <= client, (scroll, client)


def test_darcy_leaves_log10_k_alone_and_relabels_the_k_headers(tmp_path) -> None:
    """Review s52 (walk-report 1): in darcy the main effects' "mean log10 k_z_m2" (-11.33) read
    -1.148e+13 and the K headers kept m². In chromium: every converted cell is a K over
    9.869233e-13 m²/darcy (the darcy's definition), the log10 means keep the page's text, and
    each converted header reads the unit picked."""
    p = write_study(tmp_path, FACTORIAL, FAC_PARAMS)
    run_study(p, tmp_path / "out", workers=0, case_fn=fake_case, progress=False)
    page = tmp_path / "out" / "report.html"
    dom = _chromium("--dump-dom", page.as_uri() + "#unit=darcy").stdout
    assert 'data-psd-ready="1"' in dom
    cells = re.findall(r'<td data-m2="([^"]+)">([^<]*)</td>', dom)
    assert len(cells) == 2 * 12  # k_x and k_z of the 12 cases
    for m2, shown in cells:
        assert float(shown) == pytest.approx(float(m2) / 9.869233e-13, rel=1e-3)
    me = r"Main effects \(mean response per level\)</h3>(.*?)</table>"
    before = re.search(me, page.read_text(), re.S)
    after = re.search(me, dom, re.S)
    assert before is not None and after is not None and after.group(1) == before.group(1)
    assert dom.count('<span class="psd-kunit">darcy</span>') == 2
