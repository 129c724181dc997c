"""The front page (README.md) and the reference pages shipped with pkmlab (``pkmlab help TOPIC``): what the package
points a user to is there, installed from a wheel, and is the page the documentation site shows."""

import re
import subprocess
import sys
import tomllib
from importlib.resources import files
from pathlib import Path

import pytest

from pkmlab.cli import main
from pkmlab.cli.help import TOPICS, page

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "pkmlab"


def test_every_topic_is_a_page_shipped_with_the_package_and_shown_by_the_site():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "help/*.md" in pyproject["tool"]["setuptools"]["package-data"]["pkmlab"]
    assert {p.stem for p in (PACKAGE / "help").glob("*.md")} == set(TOPICS)  # no page without its topic
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for topic in TOPICS:
        assert (files("pkmlab") / "help" / f"{topic}.md").is_file()
        docs_page = ROOT / "docs" / "reference" / f"{topic}.md"
        assert docs_page.read_text(encoding="utf-8") == f'--8<-- "src/pkmlab/help/{topic}.md"\n'  # the same text
        assert f": reference/{topic}.md\n" in nav


@pytest.mark.parametrize("topic", list(TOPICS))
def test_help_prints_the_topics_page_with_where_each_link_leads(capsys, topic):
    assert main(["help", topic]) == 0
    out, err = capsys.readouterr()
    source = (PACKAGE / "help" / f"{topic}.md").read_text(encoding="utf-8")
    title = next(line for line in source.splitlines() if line.startswith("# "))
    assert out.startswith(title + "\n") and not err
    assert "](" not in out and "<!--" not in out  # links as text and where they lead, no site comments
    for target in re.findall(r"\((docs/[^)\s]+\.md)\)", out):  # every page named exists in the repository
        assert (ROOT / target).is_file(), target
    for other in re.findall(r"\(pkmlab help ([a-z-]+)\)", out):
        assert other in TOPICS
    assert len(out.splitlines()) > 20


def test_help_lists_the_topics_and_refuses_another(capsys):
    assert main(["help"]) == 0
    out = capsys.readouterr().out
    assert all(topic in out for topic in TOPICS)
    with pytest.raises(SystemExit) as exc:
        main(["help", "scenarios"])
    assert exc.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_help_reads_the_installed_package_not_the_repository(tmp_path):
    """Run from elsewhere, as an installed pkmlab is: the page comes from the package's own files."""
    proc = subprocess.run([sys.executable, "-m", "pkmlab.cli", "help", "outputs"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == page("outputs")
    assert "`130` interrupted" in proc.stdout


def test_the_package_points_to_pages_a_user_can_open():
    """No pointer to the README (a repository's file) is left in the package or the examples; every
    ``pkmlab help TOPIC`` they name is a topic."""
    sources = [p for p in [*PACKAGE.rglob("*.py"), *PACKAGE.rglob("*.toml"), *(ROOT / "examples").rglob("*.toml")]
               if "kernels" not in p.parts]
    named = set()
    for path in sources:
        text = path.read_text(encoding="utf-8")
        assert "README" not in text, path
        named.update(re.findall(r"pkmlab help ([a-z][a-z-]*)", text))
    assert named and named <= set(TOPICS), named - set(TOPICS)


def test_the_front_page_is_short_and_its_example_is_the_example_file():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 160
    block = re.search(r"```python\n(.*?)```", readme, re.DOTALL).group(1)
    example = (ROOT / "examples" / "first_machine.py").read_text(encoding="utf-8")
    assert block == example[example.index("import pkmlab"):]  # the tests run the example file itself
    for target in re.findall(r"\]\(([^)#\s]+)", readme):  # every link and picture is in the repository
        assert (ROOT / target).is_file(), target
    assert "```sh\nmake reproduce\nmake test\n```" in readme  # the quick start, exactly
