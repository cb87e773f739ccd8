"""The API reference, generated from the docstrings by pdoc into a folder of HTML (``make docs``:
``build/docs``); every warning pdoc gives (an annotation it cannot resolve, a reference it cannot
follow) fails it, listed.

Usage: ``python tools/build_docs.py [OUT] [MODULE ...]``; exit 1 naming each warning. The modules by
default: the Python API (``skatelib``), the runtime and the controller a robot runs, and the
library file's reader and writer.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

MODULES = ("skatelib", "skatelib.pipeline.api", "skatelib.runtime", "skatelib.control", "skatelib.library")


def build(out: Path, modules: tuple[str, ...] = MODULES) -> list[str]:
    """Write the reference of ``modules`` into ``out``; returns pdoc's warnings (the pages are
    written either way)."""
    import pdoc
    import pdoc.render

    pdoc.render.configure(docformat="google", footer_text="skatelib API reference")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pdoc.pdoc(*modules, output_directory=out)
    return [f"{w.category.__name__}: {w.message}" for w in caught]


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("build/docs")
    modules = tuple(sys.argv[2:]) or MODULES
    found = build(out, modules)
    for line in found:
        print(line)
    if found:
        print(f"{len(found)} warnings: fix the docstrings or annotations they name", file=sys.stderr)
        sys.exit(1)
    print(f"wrote the API reference of {', '.join(modules)} to {out}/index.html")


if __name__ == "__main__":
    main()
