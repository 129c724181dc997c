"""The documentation site (mkdocs.yml, docs/): it builds with warnings as errors, its generated references cover
what they are written from, and its pages render and search in a real headless browser."""

import functools
import http.server
import importlib.util
import json
import os
import re
import subprocess
import sys
import threading
from pathlib import Path
from urllib.parse import urlsplit

import pytest

import pkmlab
from pkmlab.cli._parser import build_parser

ROOT = Path(__file__).parents[1]
#: The packages `make docs` needs (the `docs` extra), each by the module it installs.
TOOLS = {"mkdocs": "mkdocs", "mkdocs-material": "material", "mkdocstrings": "mkdocstrings",
         "mkdocstrings-python": "mkdocstrings_handlers", "nbclient": "nbclient", "nbformat": "nbformat",
         "ipykernel": "ipykernel"}
MISSING = [package for package, module in TOOLS.items() if importlib.util.find_spec(module) is None]

pytestmark = pytest.mark.skipif(bool(MISSING), reason=f"the documentation tools are not installed: "
                                f"{', '.join(MISSING)} (pip install -e '.[docs]')")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site, built as `make docs` builds it (strict: any warning fails), into a folder of the test's own."""
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert proc.returncode == 0, proc.stderr
    assert not re.search(r"^WARNING\b", proc.stderr, re.MULTILINE), proc.stderr
    return out


def _ids(page: Path) -> set[str]:
    return set(re.findall(r'\bid="([^"]+)"', page.read_text(encoding="utf-8")))


def test_every_public_name_has_its_documentation(site):
    """Each name of `pkmlab.__all__` has an entry, with its anchor, on the page of the module that defines it."""
    missing = []
    for name, module in pkmlab._WHERE.items():
        ids = _ids(site / "reference" / "api" / module / "index.html")
        if f"pkmlab.{module}.{name}" not in ids and f"pkmlab.{module}.{name}.{name}" not in ids:
            missing.append(f"pkmlab.{module}.{name}")
    assert not missing, missing
    assert set(pkmlab.__all__) == {"__version__", *pkmlab._WHERE}


def test_the_papers_own_formulation_is_documented_name_by_name(site):
    """`pkmlab.paper`'s modules, not re-exported by `pkmlab`: each name of their `__all__` has its entry."""
    import pkmlab.paper.dynamics
    import pkmlab.paper.kinematics

    for module in (pkmlab.paper.kinematics, pkmlab.paper.dynamics):
        stem = module.__name__.removeprefix("pkmlab.")
        ids = _ids(site / "reference" / "api" / stem / "index.html")
        assert {f"{module.__name__}.{name}" for name in module.__all__} <= ids, stem
    assert "pkmlab.paper.geometry.Planar3RRR" in _ids(site / "reference" / "api" / "paper.geometry" / "index.html")


def test_docstrings_cross_references_are_links(site):
    """Sphinx's roles in docstrings (":class:`~pkmlab.errors.IncompleteSolutionWarning`") show as code, linked to
    the entry they name where the site has one, never as the role's raw text."""
    pages = sorted((site / "reference" / "api").glob("*/index.html"))
    assert len(pages) == len(set(pkmlab._WHERE.values())) + 3  # and pkmlab.paper's geometry, kinematics, dynamics
    role = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):<code>")
    for page in pages:
        assert not role.search(page.read_text(encoding="utf-8")), page
    kinematics = (site / "reference" / "api" / "algorithms.kinematics" / "index.html").read_text(encoding="utf-8")
    assert 'href="../errors/#pkmlab.errors.IncompleteSolutionWarning"' in kinematics


def test_command_line_reference_is_the_parser(site):
    """Every command of the parser has its section, with every one of its options, on the command line page."""
    page = site / "reference" / "cli" / "index.html"
    html, ids = page.read_text(encoding="utf-8"), _ids(page)
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert len(sub.choices) >= 10
    for name, command in sub.choices.items():
        assert f"pkmlab-{name}" in ids, name
        section = html.split(f'id="pkmlab-{name}"', 1)[1].split("<h2", 1)[0]
        for action in command._actions:
            for flag in action.option_strings:
                if flag not in ("-h", "--help"):
                    assert f"<code>{flag}</code>" in section, (name, flag)


def test_performance_tables_are_the_results(site):
    """The performance page has one row per timed operation of benchmarks/results.json, with its median."""
    results = json.loads((ROOT / "benchmarks" / "results.json").read_text(encoding="utf-8"))["results"]
    html = (site / "performance" / "index.html").read_text(encoding="utf-8")
    per_op = [r for r in results.values() if r["kind"] == "per_op"]
    assert per_op
    for row in per_op:
        assert f"{row['per_second']:,.0f} {row['op']}s/s" in html, row["name"]
    assert html.count("<tr>") >= len(results)  # one row per result, and the header rows


def test_tutorials_show_what_their_code_printed_and_drew_in_this_build(site):
    """Every Python block of the tutorials and how-to guides ran as the site built: the paper's tutorial shows the
    output of its blocks and three figures, each a PNG the build drew (none is in docs/), and so on."""
    figures = {"tutorials/paper": 3, "tutorials/delta-stewart": 2, "tutorials/your-machine": 1,
               "how-to/figures": 1, "how-to/many-plants": 1}
    for page, count in figures.items():
        html = (site / page / "index.html").read_text(encoding="utf-8")
        drawn = re.findall(r'<img [^>]*src="(\.\./plots/[^"]+\.png)"', html)
        assert len(drawn) == count, (page, drawn)
        for src in drawn:
            png = (site / page / src).resolve()
            assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000, png
            assert not list((ROOT / "docs").rglob(png.name)), png.name  # drawn, not pasted
    paper = (site / "tutorials" / "paper" / "index.html").read_text(encoding="utf-8")
    assert paper.count(">Output<") >= 2  # what its blocks printed: the assembly modes, a run's summary


def _hook(name: str):
    """The site's build hook ``docs/_hooks/NAME.py`` as a module: ``run_pages`` runs the tutorials' blocks,
    ``render_notebook`` the notebook tour."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / "_hooks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_block_that_fails_fails_the_build_naming_its_page_and_block():
    """The page runner (docs/_hooks/run_pages.py) turns an error of a block into the build's error."""
    run_pages = _hook("run_pages")
    from mkdocs.exceptions import PluginError

    page = ("```python\nx = 1\nprint(x + 1)\n```\n\ntext\n\n"
            "```python\nimport pkmlab\npkmlab.load('no_such_machine')\n```\n")
    with pytest.raises(PluginError, match=r"^tutorials/broken\.md: its Python block 2 fails as written:\n"):
        run_pages._run_page("tutorials/broken.md", page, None, [])
    assert run_pages._run_page("tutorials/fine.md", page.split("text")[0], None, []) == [("2\n", [])]


def test_the_figures_of_a_block_are_its_own():
    """A block's figures are those it left open, saved into the site; one open before it (another page's, a test's)
    is not taken."""
    import types

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_pages = _hook("run_pages")
    # the site's files as MkDocs makes them during a build (File.generated reads the plugin being run)
    run_pages.File = types.SimpleNamespace(generated=lambda config, name, content: types.SimpleNamespace(
        src_uri=name, content=content))
    files = []
    elsewhere = plt.figure()
    open_before = plt.get_fignums()  # elsewhere's, and any another test left open
    try:
        page = ("```python\nimport matplotlib.pyplot as plt\nfig, ax = plt.subplots()\nax.plot([0, 1], [1, 0])\n```\n\n"
                "```python\nprint('no figure')\n```\n")
        outputs = run_pages._run_page("how-to/drawn.md", page, None, files)
        assert outputs == [("", ["how-to/plots/drawn-1-1.png"]), ("no figure\n", [])]
        assert [f.src_uri for f in files] == ["how-to/plots/drawn-1-1.png"]
        assert files[0].content[:8] == b"\x89PNG\r\n\x1a\n"
        assert plt.get_fignums() == open_before  # the block's own figure closed once saved, the others left
    finally:
        plt.close(elsewhere)


@pytest.fixture(scope="module")
def tour(site):
    """The notebook tour (examples/tour.ipynb) as the build ran it in a Jupyter kernel, published beside its page."""
    import nbformat

    return nbformat.read(site / "tutorials" / "tour.ipynb", as_version=4)


def _outputs(cell) -> dict:
    data = {}
    for output in cell.outputs:
        assert output.output_type != "error", "".join(output.get("traceback", []))
        data.update(output.get("data", {}))
    return data


def test_every_cell_of_the_tour_ran_in_the_build(tour):
    source = json.loads((ROOT / "examples" / "tour.ipynb").read_text(encoding="utf-8"))
    assert [c.source for c in tour.cells] == ["".join(c["source"]) for c in source["cells"]]
    for cell in tour.cells:
        if cell.cell_type == "code":
            assert cell.execution_count is not None and cell.outputs, cell.source
            _outputs(cell)


@pytest.mark.parametrize(("last_line", "title"), [
    ("model", "paper (3-R*RR)"),
    ("ik", "Inverse kinematics"),
    ("fk", "Forward kinematics: every assembly mode"),
    ("results['fast']", "Run of fast"),
    ("delta", "delta (3-R*US)"),
    ("scenario", "Scenario"),
    ("run", "Run of"),
])
def test_objects_show_as_tables_in_the_tour(tour, last_line, title):
    """pkmlab's objects show as tables in Jupyter: the views layer registers them with IPython's HTML formatter on
    ``import pkmlab`` (the objects themselves know nothing of their display)."""
    cell = next(c for c in tour.cells if c.cell_type == "code" and c.source.strip().splitlines()[-1] == last_line)
    html = _outputs(cell).get("text/html", "")
    assert "<table" in html and title in html


def test_machines_and_runs_draw_as_plotly_figures_in_the_tour(tour):
    for start in ("pkmlab.draw(", "pkmlab.plot(", "pkmlab.show("):
        cell = next(c for c in tour.cells if c.cell_type == "code" and c.source.startswith(start))
        data = _outputs(cell)
        assert "application/vnd.plotly.v1+json" in data or "plotly" in data.get("text/html", "").lower()


def test_the_tour_page_shows_its_tables_and_live_figures_offline(server, browser):
    """The tour's page: the notebook's text, its code, its tables and its three Plotly figures drawn by the
    site's own copy of Plotly (nothing fetched from elsewhere, no script error)."""
    page, errors = _open(browser, f"{server}/tutorials/tour/", server)
    try:
        page.wait_for_selector("article .js-plotly-plot .main-svg")
        article = page.inner_text("article.md-content__inner")
        assert "A second machine: the Delta robot" in article and "pkmlab.simulate(scenario)" in article
        assert page.locator("article .js-plotly-plot").count() == 3
        assert page.locator("article table").count() >= 7
        assert not page.locator("article p", has_text="PKMLAB_NOTEBOOK_OUTPUT").count()  # every output in place
        page.wait_for_timeout(200)
        assert not errors, errors
    finally:
        page.close()


def test_a_cell_that_fails_fails_the_build_naming_it(tmp_path):
    import nbformat
    from mkdocs.exceptions import PluginError

    cells = [nbformat.v4.new_markdown_cell("# A notebook"), nbformat.v4.new_code_cell("x = 1"),
             nbformat.v4.new_code_cell("import pkmlab\npkmlab.load('no_such_machine')")]
    path = tmp_path / "broken.ipynb"
    nbformat.write(nbformat.v4.new_notebook(cells=cells), path)
    with pytest.raises(PluginError, match=r"^broken\.ipynb: its code cell 2 fails: InvalidParameterError: source "
                                          r"must be a preset"):
        _hook("render_notebook")._execute(path)


def test_changelog_is_included(site):
    html = (site / "changelog" / "index.html").read_text(encoding="utf-8")
    first_heading = re.search(r"^## (.+)$", (ROOT / "CHANGELOG.md").read_text(encoding="utf-8"), re.MULTILINE)
    assert first_heading.group(1) in html
    assert "--8&lt;--" not in html and "--8<--" not in html  # the include was done, not shown


# ------------------------------------------------------------------ in a real browser
@pytest.fixture(scope="module")
def server(site):
    """The built site over HTTP on the loopback interface: its search runs in a web worker, which a page opened
    from a file may not start."""
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):  # a line per request would bury a failure's own output
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(site)))
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


def _open(browser, url: str, base: str):
    """The page at ``url``, loaded, and the list its console errors, uncaught exceptions and any request for
    something outside the site go to (the site reads offline: no web fonts, no scripts from elsewhere)."""
    page = browser.new_page()
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("request", lambda r: errors.append(f"fetched {r.url}") if not r.url.startswith(base) else None)
    page.goto(url, wait_until="load")
    return page, errors


PAGES = {
    "": "pkmlab",
    "getting-started/": "A first machine in Python",
    "tutorials/paper/": "The paper, step by step",
    "tutorials/your-machine/": "Legs without a closed form",
    "how-to/singularities/": "Check a path for singularities",
    "reference/scenario-files/": "A real plant and its sensors",
    "reference/outputs/": "nothing of yours is deleted",
    "development/": "Layout",
    "theory/paper/": "Trajectory-tracking control of a planar 3-RRR parallel",
    "theory/glossary/": "One name per quantity",
    "reference/api/algorithms.kinematics/": "forward_kinematics",
    "reference/cli/": "pkmlab fk",
    "performance/": "Timed operations",
    "changelog/": "Unreleased",
}


def test_pages_render_without_errors(server, browser):
    for path, text in PAGES.items():
        page, errors = _open(browser, f"{server}/{path}", server)
        try:
            page.wait_for_selector("article.md-content__inner")
            assert text in page.inner_text("article.md-content__inner"), path
            assert page.locator("nav.md-nav--primary").count() == 1, path  # the theme's navigation is there
            page.wait_for_timeout(200)  # late script errors
            assert not errors, (path, errors)
        finally:
            page.close()


def test_search_finds_forward_kinematics(server, browser):
    from playwright.sync_api import TimeoutError as PageTimeout

    page, errors = _open(browser, f"{server}/", server)
    try:
        # the search index is built in a web worker as the page opens (seconds, or a minute on a machine busy with
        # the other tests), saying "Initializing search" until it is ready; a query typed before may be answered by
        # nothing: typed key by key once it is ready (as in the header's search box), and again should the results
        # not show
        page.wait_for_function("() => !/Initializing/.test(document.querySelector('.md-search-result__meta')"
                               ".textContent)", timeout=240_000)
        box = page.locator("input.md-search__input")
        for attempt in range(6):
            box.fill("")
            box.press_sequentially("forward_kinematics")
            try:  # (the results of the whole query: those of a prefix typed before may show first)
                page.wait_for_selector('.md-search-result__item a[href*="#pkmlab.algorithms.kinematics.forward_'
                                       'kinematics"]', timeout=10_000)
                break
            except PageTimeout:
                if attempt == 5:
                    raise
        links = page.eval_on_selector_all(".md-search-result__item a", "as => as.map(a => a.href)")
        found = {(urlsplit(href).path, urlsplit(href).fragment) for href in links}  # the query highlights the word
        assert ("/reference/api/algorithms.kinematics/", "pkmlab.algorithms.kinematics.forward_kinematics") in found, \
            links
        assert not errors, errors
    finally:
        page.close()
