"""Interactive views (pkmlab.views): REPORT.html and ``pkmlab view``, opened in headless Chromium."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import run

import pkmlab
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.views.html import write_html
from pkmlab.views.run import RunView

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.fixture(scope="module")
def nominal_result():
    return pkmlab.simulate(pkmlab.paper_scenario("nominal"))


@pytest.fixture(scope="module")
def result_dir(tmp_path_factory, nominal_result):
    """A folder of `pkmlab simulate --no-figures` of the paper's nominal case."""
    out = tmp_path_factory.mktemp("views") / "nominal"
    code = pkmlab.cli.main(["simulate", str(EXAMPLES / "nominal.toml"), "--out", str(out), "--no-figures", "--quiet"])
    assert code == 0
    return out


# ------------------------------------------------------------------ the view's data
def test_the_view_draws_the_run_it_was_given(nominal_result):
    view = RunView.from_result(nominal_result)
    assert view.name == nominal_result.scenario.name  # (not the name of a series it draws)
    assert view.samples[0] == 0 and view.samples[-1] == len(nominal_result.t) - 1 and len(view.samples) <= 150
    # the tracked point of the drawn machine is the platform's centroid: the mean of its vertices (the 3-RRR's
    # attachment points form an equilateral triangle about it)
    vertices = view.joints[:, :, -1, :]
    np.testing.assert_allclose(vertices.mean(axis=1), nominal_result.pose[view.samples, :2], atol=1e-12)
    # each leg's links keep their lengths in every frame
    model = nominal_result.scenario.model
    links = np.linalg.norm(np.diff(view.joints, axis=2), axis=-1)
    for j in range(2):  # the actuated and the passive link of every leg: the lengths of their bodies' tips
        lengths = [np.hypot(*leg.bodies[j].tip) for leg in model.description.legs]
        np.testing.assert_allclose(links[:, :, j], np.broadcast_to(lengths, links[:, :, j].shape), rtol=1e-12)
    np.testing.assert_allclose(view.series["path error"][1]["|p - p_d|"], nominal_result.path_error, rtol=0, atol=0)


def test_view_of_a_folder_is_the_view_of_the_run(result_dir, nominal_result):
    from pkmlab.views.folder import read_result_views

    (view,) = read_result_views(result_dir)
    direct = RunView.from_result(nominal_result)
    # rebuilt from the CSV's actuator angles by forward kinematics and branch following
    np.testing.assert_allclose(view.joints, direct.joints, atol=1e-9)
    assert view.summary["max_path_error_m"] == nominal_result.summary()["max_path_error_m"]
    assert "[trajectory]" in view.scenario_text


def test_view_command_adds_the_page_to_the_result(result_dir, capsys):
    code, out, err = run(capsys, "view", result_dir, "--json")
    assert code == 0, err
    page = result_dir / "REPORT.html"
    assert json.loads(out)["html"] == str(page) and page.stat().st_size > 4_000_000  # Plotly embedded
    text = page.read_text()
    assert "<script src=" not in text and "<link " not in text  # offline: Plotly's code is in the page
    manifest = json.loads((result_dir / "pkmlab-manifest.json").read_text())
    assert "REPORT.html" in manifest["files"]
    # the folder stays a result that pkmlab simulate may replace
    code, _out, err = run(capsys, "simulate", EXAMPLES / "nominal.toml", "--out", result_dir, "--no-figures",
                          "--quiet")
    assert code == 0, err


def test_every_figure_of_a_result_has_its_unit(result_dir, capsys):
    """summary.json and REPORT.html's table gave ``peak_effort 0.319, 0.293, 0.294`` with no unit."""
    import re

    summary = json.loads((result_dir / "summary.json").read_text())
    assert summary["units"]["peak_effort"] == "N*m" and summary["units"]["max_joint_error"] == "rad"
    assert summary["units"]["max_path_error_m"] == "m" and summary["units"]["min_abs_S"] == ""
    code, _out, err = run(capsys, "view", result_dir, "--out", result_dir.parent / "units.html")
    assert code == 0, err
    rows = dict(re.findall(r"<tr><th>([^<]+)</th><td>([^<]*)</td></tr>",
                           (result_dir.parent / "units.html").read_text()))
    assert rows["peak_effort"].endswith(" N·m") and rows["max_path_error_m"].endswith(" m"), rows
    assert rows["max_joint_error"].endswith(" rad") and "units" not in rows


def test_a_prismatic_machines_efforts_are_in_newtons():
    from pkmlab.simulation.result import summary_units
    from pkmlab.views.html import summary_table

    table = summary_table({"peak_effort": [1.5, 2.0, 2.5], "max_joint_error": 1e-5},
                          summary_units(pkmlab.load("3prr")))
    assert "<th>peak_effort</th><td>1.5, 2, 2.5 N</td>" in table, table
    assert "<th>max_joint_error</th><td>1e-05 m</td>" in table, table


@pytest.mark.parametrize("damage, message", [
    ("truncate", "row 1572 (line 1573) has"),
    ("rename", "missing column tau2"),
    ("nothing", "is not a result folder: no run.csv"),
])
def test_view_of_a_damaged_result_is_one_line_and_writes_nothing(tmp_path, result_dir, capsys, damage, message):
    folder = tmp_path / "r"
    shutil.copytree(result_dir, folder)
    (folder / "REPORT.html").unlink(missing_ok=True)
    csv = folder / "run.csv"
    text = csv.read_text()
    if damage == "truncate":
        csv.write_text(text[: len(text) - 40])
    elif damage == "rename":
        csv.write_text(text.replace("tau2", "torque2", 1))
    else:
        csv.unlink()
    before = sorted(p.name for p in folder.iterdir())
    code, _out, err = run(capsys, "view", folder)
    assert code == 1 and err.count("\n") == 1 and message in err, err
    assert sorted(p.name for p in folder.iterdir()) == before


# ------------------------------------------------------------------ in a real browser
def _open(browser, path: Path, figure: str = "run-0", height: int = 1300):
    """The page at ``path`` once its figure ``figure`` is drawn, and the list its console errors and any request
    for something other than the file itself go to."""
    page = browser.new_page(viewport={"width": 1400, "height": height})
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    # offline: any request for something other than the file itself is an error
    page.on("request", lambda r: errors.append(f"fetched {r.url}") if not r.url.startswith("file:") else None)
    page.goto(path.as_uri())
    page.wait_for_selector(f"#{figure} .main-svg")
    return page, errors


GEOMETRY = """() => {
  const gd = document.getElementById('run-0'), L = gd._fullLayout, box = gd.getBoundingClientRect();
  const area = a => ({x0: box.left + L[a.x]._offset, x1: box.left + L[a.x]._offset + L[a.x]._length,
                      y0: box.top + L[a.y]._offset, y1: box.top + L[a.y]._offset + L[a.y]._length});
  const series = [];
  for (let i = 2; L['xaxis' + i]; i++) series.push({...area({x: 'xaxis' + i, y: 'yaxis' + i}), axis: 'xaxis' + i});
  const rail = gd.querySelector('.slider-rail-rect').getBoundingClientRect();
  const slider = gd.querySelector('.slider-container').getBoundingClientRect();
  return {machine: area({x: 'xaxis', y: 'yaxis'}), series, rail: {x0: rail.left, x1: rail.right, y: rail.top +
          rail.height / 2}, slider: {y0: slider.top, y1: slider.bottom}, scrollY: window.scrollY};
}"""
CURSOR = """(axis) => { const gd = document.getElementById('run-0'), L = gd._fullLayout;
  const t = gd.data.filter(d => d.xaxis === axis.replace('axis', '') && d.hoverinfo === 'skip')[0].x[0];
  return gd.getBoundingClientRect().left + L[axis]._offset + L[axis].l2p(t); }"""


def _pixels(page) -> np.ndarray:
    from io import BytesIO

    from PIL import Image

    return np.asarray(Image.open(BytesIO(page.screenshot())).convert("RGB")).astype(int)


def _settled_pixels(page, tries: int = 30) -> np.ndarray:
    """A screenshot once the drawing has settled: two in a row alike (a busy machine may still be drawing fonts,
    anti-aliasing or a transition when a fixed wait is over)."""
    last = _pixels(page)
    for _ in range(tries):
        page.wait_for_timeout(150)
        now = _pixels(page)
        if np.array_equal(now, last):
            return now
        last = now
    return last


def test_the_slider_moves_the_machine_and_nothing_else(browser, tmp_path, nominal_result):
    path = write_html(tmp_path / "nominal.html", [RunView.from_result(nominal_result)], "nominal")
    page, errors = _open(browser, path)
    page.wait_for_timeout(300)  # the first drawing settled (fonts, anti-aliasing) before the first screenshot
    geometry = page.evaluate(GEOMETRY)
    cursors_before = [page.evaluate(CURSOR, s["axis"]) for s in geometry["series"]]
    before = _settled_pixels(page)
    rail = geometry["rail"]
    page.mouse.click(rail["x0"] + 0.6 * (rail["x1"] - rail["x0"]), rail["y"])
    page.mouse.move(1, 1)  # away from the figure, whose tool bar shows while the mouse is over it
    for _ in range(50):  # the frame shown (a busy machine may take a moment), then its drawing settled
        if page.evaluate(CURSOR, geometry["series"][0]["axis"]) > cursors_before[0]:
            break
        page.wait_for_timeout(100)
    page.wait_for_timeout(400)
    after = _settled_pixels(page)
    cursors_after = [page.evaluate(CURSOR, s["axis"]) for s in geometry["series"]]
    assert errors == []
    assert all(b < a for b, a in zip(cursors_before, cursors_after, strict=True))  # every cursor went forward
    changed = np.abs(after - before).sum(axis=2) > 30
    ys, xs = np.nonzero(changed)
    m = geometry["machine"]
    in_machine = (xs >= m["x0"] - 12) & (xs <= m["x1"] + 12) & (ys >= m["y0"] - 12) & (ys <= m["y1"] + 12)
    assert in_machine.sum() > 500  # the machine moved
    near_cursor = np.zeros_like(in_machine)
    for s, x_old, x_new in zip(geometry["series"], cursors_before, cursors_after, strict=True):
        rows = (ys >= s["y0"] - 2) & (ys <= s["y1"] + 2)
        near_cursor |= rows & ((np.abs(xs - x_old) <= 3) | (np.abs(xs - x_new) <= 3))
    on_slider = (ys >= geometry["slider"]["y0"] - 30) & (ys <= geometry["slider"]["y1"] + 5)
    elsewhere = ~(in_machine | near_cursor | on_slider)
    # Plotly redraws a plot's curves under its moving cursor, and a busy machine may anti-alias a curve's edge
    # differently (seen: 1 to 12 pixels): a changed pixel within a pixel of a stroke drawn in both screenshots is
    # that edge. Anything else (a curve moved, added or gone, a label changed) leaves the stroke of one of them.
    edge = _near_stroke(before) & _near_stroke(after)
    redrawn = elsewhere & edge[ys, xs]
    moved = elsewhere & ~edge[ys, xs]
    stray = list(zip(xs[moved][:5], ys[moved][:5], strict=True))
    assert moved.sum() <= 2, (f"{moved.sum()} pixels changed away from the machine, cursors, slider and the curves' "
                              f"edges, e.g. at {stray}; cursors {cursors_before} -> {cursors_after}")
    assert redrawn.sum() <= 50  # an edge's anti-aliasing, not a curve drawn again elsewhere


def _near_stroke(pixels: np.ndarray) -> np.ndarray:
    """Where a screenshot has drawing (a pixel well away from the white background) within one pixel."""
    from scipy.ndimage import binary_dilation

    return binary_dilation(np.abs(255 - pixels).sum(axis=2) > 150, iterations=1)


def test_hover_shows_the_values(browser, tmp_path, nominal_result):
    path = write_html(tmp_path / "nominal.html", [RunView.from_result(nominal_result)], "nominal")
    page, errors = _open(browser, path)
    k = 700
    t, e = float(nominal_result.t[k]), float(nominal_result.path_error[k])
    x, y = page.evaluate("""([t, e]) => { const gd = document.getElementById('run-0'), L = gd._fullLayout;
        const box = gd.getBoundingClientRect();
        return [box.left + L.xaxis2._offset + L.xaxis2.l2p(t), box.top + L.yaxis2._offset + L.yaxis2.l2p(e)]; }""",
                         [t, e])
    page.mouse.move(x, y)
    page.wait_for_selector(".hoverlayer .hovertext", timeout=5000)
    text = page.evaluate("() => document.querySelector('.hoverlayer').textContent")
    assert "|p - p_d| =" in text and "t = " in text, text
    shown = float(text.split("|p - p_d| = ")[1].split(" m")[0].replace("µ", "e-6").replace("μ", "e-6"))
    assert shown == pytest.approx(e, rel=2e-3, abs=2e-8)
    assert errors == []


def test_a_spatial_machine_is_drawn_in_3d(browser, tmp_path):
    scenario = pkmlab.load_scenario(EXAMPLES / "delta_pick_and_place.toml")
    view = RunView.from_result(pkmlab.simulate(scenario))
    assert view.spatial
    path = write_html(tmp_path / "delta.html", [view], "delta")
    page, errors = _open(browser, path)
    assert page.evaluate("() => document.getElementById('run-0')._fullLayout.scene !== undefined")
    assert page.evaluate("() => document.getElementById('run-0').data.filter(d => d.type === 'scatter3d').length") >= 5
    assert errors == []


def test_singularity_map_is_interactive(browser, tmp_path, capsys):
    out = tmp_path / "map.html"
    code, _out, err = run(capsys, "singularity-map", "--mode", "-", "+", "-", "--resolution", "60", "--out", out)
    assert code == 0, err
    page, errors = _open(browser, out, "map", 800)
    # hover the grid point nearest (0.25, 0.21): the paper's circle's centre, reachable in mode (-, +, -)
    x, y = page.evaluate("""() => { const gd = document.getElementById('map'), L = gd._fullLayout;
        const box = gd.getBoundingClientRect();
        return [box.left + L.xaxis._offset + L.xaxis.l2p(0.25), box.top + L.yaxis._offset + L.yaxis.l2p(0.21)]; }""")
    page.mouse.move(x, y)
    page.wait_for_selector(".hoverlayer .hovertext", timeout=5000)
    text = page.evaluate("() => document.querySelector('.hoverlayer').textContent")
    assert "working mode (−, +, −)" in text and "S = " in text and "α = 0 rad" in text, text
    s_shown = float(text.split("S = ")[1].split("working")[0])
    model = Planar3RRR.paper()
    ik = kin.inverse_kinematics(model, [float(text.split("x = ")[1].split(" m")[0]),
                                           float(text.split("y = ")[1].split(" m")[0]), 0.0], mode=(-1, 1, -1))
    assert s_shown == pytest.approx(float(ik.S), abs=1e-4)  # the S of that pose, computed anew
    assert errors == []

