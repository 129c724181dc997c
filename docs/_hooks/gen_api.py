"""The Python API reference: one page per module that ``pkmlab`` re-exports, written at build time from the table
of public names in ``pkmlab/__init__.py`` (``_WHERE``) and rendered by mkdocstrings.

``pkmlab`` imports its public names lazily (PEP 562), so a static reading of the package sees ``__all__`` but
not where each name lives; the table says it, and the pages follow it: a name added to the public API gets its
documentation, in its module's page, without editing the docs. Each page shows only the module's public names
(its other functions are the package's inside, documented in the source).
"""

from __future__ import annotations

import functools
import re
import sys
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
# The documented pkmlab is this checkout's, even where another one is installed.
sys.path.insert(0, str(ROOT / "src"))

FOLDER = "reference/api"
#: The paper's own formulation (``pkmlab.paper``: the paper's 3-RRR in its 7-vector ``(θ, φ, α)``), documented
#: module by module, each by its ``__all__``: not re-exported by ``pkmlab``, public all the same.
PAPER_MODULES = ("paper.geometry", "paper.kinematics", "paper.dynamics")


@functools.cache
def public_modules() -> dict[str, list[str]]:
    """Each module (dotted, under ``pkmlab``) and the public names it defines, in the order of ``_WHERE``."""
    import pkmlab

    modules: dict[str, list[str]] = {}
    for name, module in pkmlab._WHERE.items():
        modules.setdefault(module, []).append(name)
    return modules


@functools.cache
def paper_modules() -> dict[str, list[str]]:
    """Each module of :data:`PAPER_MODULES` and its public names (its ``__all__``, else the classes and functions
    it defines)."""
    import importlib

    modules = {}
    for module in PAPER_MODULES:
        found = importlib.import_module(f"pkmlab.{module}")
        names = getattr(found, "__all__", None) or [
            name for name, value in vars(found).items()
            if not name.startswith("_") and getattr(value, "__module__", None) == found.__name__]
        modules[module] = list(names)
    return modules


def page_path(module: str) -> str:
    return f"{FOLDER}/{module}.md"


def shadows_submodule(module: str, name: str) -> bool:
    """Whether the public ``name`` of ``module`` is also the name of one of its submodules (``pkmlab.study.sweep``,
    the function imported over the module of the same name): a static reading takes the path for the submodule,
    so the name is documented where it is defined, ``pkmlab.study.sweep.sweep``."""
    folder = ROOT / "src" / "pkmlab" / module.replace(".", "/")
    return (folder / f"{name}.py").is_file() or (folder / name / "__init__.py").is_file()


def identifier(module: str, name: str) -> str:
    """Where the documentation of the public ``name`` is: its anchor on its module's page."""
    return f"pkmlab.{module}.{name}.{name}" if shadows_submodule(module, name) else f"pkmlab.{module}.{name}"


def module_page(module: str, names: list[str]) -> str:
    members = "\n".join(f"        - {name}" for name in names if not shadows_submodule(module, name))
    lines = [f"::: pkmlab.{module}", "    options:", "      show_root_heading: true", "      heading_level: 1",
             f"      members:\n{members}" if members else "      members: false"]
    for name in names:
        if shadows_submodule(module, name):
            lines += ["", f"::: {identifier(module, name)}", "    options:", "      show_root_heading: true",
                      "      heading_level: 2"]
    return "\n".join(lines) + "\n"


def index_page(modules: dict[str, list[str]]) -> str:
    rows = [f"| [`pkmlab.{name}`]({module}.md#{identifier(module, name)}) | `pkmlab.{module}` |"
            for module, names in modules.items() for name in names]
    return "\n".join([
        "::: pkmlab",
        "    options:",
        "      show_root_heading: true",
        "      heading_level: 1",
        "      members: false",
        "",
        "## Public names",
        "",
        "Every name below is imported from `pkmlab` itself (`pkmlab.forward_kinematics`, ...); the module that "
        "defines it is where its documentation is.",
        "",
        "| name | defined in |",
        "| --- | --- |",
        *rows,
        "",
        "## The paper's own formulation",
        "",
        "`pkmlab.paper` keeps the paper's 3-RRR in the paper's own terms (its 7-vector `(θ, φ, α)`, its equations "
        "one function each): the independent formulation pkmlab's general machinery is checked against. Import "
        "it from its modules:",
        "",
        *(f"- [`pkmlab.{module}`]({module}.md)" for module in PAPER_MODULES),
        "",
    ])


# Sphinx's roles, which many docstrings use (":class:`~pkmlab.errors.PkmlabError`"), come out of Markdown as the
# role's name followed by the target as code. Each becomes the code alone, as Sphinx shows it (the last part only
# after a "~"), linked to the target's entry when the site has one: an optional cross-reference, which the
# autorefs plugin resolves where it can and leaves as text where it cannot, without a warning.
_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const):<code>(~?)([^<]*)</code>")


def _candidates(target: str, module: str | None) -> list[str]:
    """The identifiers a role's target may name, likeliest first: a public name of ``pkmlab`` (``pkmlab.load``,
    ``SimulationResult``) at its definition, a name relative to the page's module, the target as written."""
    top = {name: identifier(where, name) for where, names in public_modules().items() for name in names}
    bare = target.removeprefix("pkmlab.")
    if bare in top:
        return [top[bare], target]
    if module is None or target.startswith("pkmlab."):
        return [target]
    # A dotted name outside pkmlab is another package's (numba.set_num_threads) or a class's member: as written
    # first, so that the text shown where it resolves nowhere is the docstring's own.
    relative = f"pkmlab.{module}.{target}"
    return [target, relative] if "." in target else [relative, target]


def _role_as_code(match: re.Match, module: str | None) -> str:
    tilde, target = match.groups()
    code = f"<code>{target.rsplit('.', 1)[-1] if tilde else target}</code>"
    first, *rest = _candidates(target, module)
    # autorefs tries the identifier, then the slug: the two likeliest candidates.
    slug = f' slug="{rest[0]}"' if rest else ""
    return f'<autoref identifier="{first}"{slug} optional>{code}</autoref>'


def on_page_content(html: str, page, config, files) -> str:
    if not page.file.src_uri.startswith(f"{FOLDER}/"):
        return html
    stem = page.file.src_uri.removeprefix(f"{FOLDER}/").removesuffix(".md")
    module = None if stem == "index" else stem
    return _ROLE.sub(lambda m: _role_as_code(m, module), html)


def on_files(files, config):
    modules = public_modules()
    files.append(File.generated(config, f"{FOLDER}/index.md", content=index_page(modules)))
    for module, names in {**modules, **paper_modules()}.items():
        files.append(File.generated(config, page_path(module), content=module_page(module, names)))
    return files


if __name__ == "__main__":
    for module, names in public_modules().items():
        print(page_path(module), ", ".join(names))
