"""What each generated kernel module was derived from, so that knowing it is current need not derive it again.

``make derive`` records, for every module it writes, two digests in ``kernels/provenance.json``: of the
derivation's inputs (SymPy's version and the sources of pkmlab a derivation reads, :data:`INPUTS`) and of the
text it wrote. While both still hold, the module is the text the derivation gives: a derivation is a function of
its inputs. When either does not (a source edited, a module edited by hand, another SymPy), only deriving again
can tell — the SymPy derivation of the Stewart platform takes about 20 s, which is what this record saves a check.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]
#: The record, beside the modules it describes.
RECORD = PACKAGE / "kernels" / "provenance.json"
#: The sources of pkmlab a derivation reads (folders whole): the derivations and the core's templates, the
#: machine descriptions and the presets, and the validation they import.
INPUTS = ("codegen", "description", "_keys.py", "_validate.py", "errors.py")


def inputs_digest() -> str:
    """The digest of SymPy's version and of every file of :data:`INPUTS`, names and contents."""
    import sympy as sp

    from .._compile_cache import digest_sources

    files = [file for entry in INPUTS for file in
             (sorted((PACKAGE / entry).rglob("*.py")) if (PACKAGE / entry).is_dir() else [PACKAGE / entry])]
    return digest_sources(hashlib.sha256(f"sympy {sp.__version__}\n".encode()), PACKAGE, files)


def text_digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _read() -> dict:
    try:
        return json.loads(RECORD.read_text())
    except (OSError, ValueError):
        return {}


def record(written: dict[str, str]) -> None:
    """Record the modules just written (``{file name: text}``) as derived from today's inputs."""
    entries = _read()
    inputs = inputs_digest()
    entries.update({name: {"inputs": inputs, "text": text_digest(text)} for name, text in written.items()})
    RECORD.write_text(json.dumps(dict(sorted(entries.items())), indent=1) + "\n")


def recorded_current(path: Path) -> bool:
    """Whether the generated module at ``path`` is, by the record, what its derivation gives today: written by
    ``make derive`` from the inputs of today and not changed since. False means unknown, not stale."""
    entry = _read().get(path.name)
    return (entry is not None and path.exists() and entry.get("text") == text_digest(path.read_text())
            and entry.get("inputs") == inputs_digest())
