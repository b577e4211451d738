"""Writes one benchmark's section into docs/benchmarks.md, between its markers."""

from __future__ import annotations

import datetime
import platform
import re
import sys
from pathlib import Path

DOC = Path(__file__).resolve().parent.parent / "docs" / "benchmarks.md"
HEADER = """# Benchmarks

Each section is written by the tool named in it, with the command that produced it. Machines
here are shared and noisy: compare the ratios measured within one run, not absolute times
across sections.
"""


def machine() -> str:
    """A one-line description of the machine and Python."""
    return f"{platform.machine()}, {platform.processor() or 'cpu'}, Python {sys.version.split()[0]}"


def write_section(name: str, markdown: str, command: str) -> Path:
    """Replace (or append) the section ``name`` of docs/benchmarks.md.

    Args:
        name: Section key, e.g. ``"kinematics"``.
        markdown: The section body (with its own ``##`` heading).
        command: The command line that produced it.

    Returns:
        The path of the document.
    """
    today = datetime.date.today().isoformat()
    body = (f"<!-- bench:{name} -->\n{markdown.rstrip()}\n\nProduced by `{command}` on {today} "
            f"({machine()}).\n<!-- /bench:{name} -->")
    return replace_block(DOC, f"bench:{name}", body, HEADER)


def replace_block(doc: Path, marker: str, block: str, header: str = "") -> Path:
    """Replace the block between ``<!-- marker -->`` and ``<!-- /marker -->`` of ``doc``.

    ``block`` includes both marker lines. A document without the block gets it appended (a
    missing document starts with ``header``). The rest of the document is kept as it is.
    """
    text = doc.read_text(encoding="utf-8") if doc.exists() else header
    pattern = re.compile(rf"<!-- {re.escape(marker)} -->.*?<!-- /{re.escape(marker)} -->", re.S)
    text = pattern.sub(lambda _: block, text) if pattern.search(text) else (
        text.rstrip() + "\n\n" + block + "\n")
    doc.parent.mkdir(parents=True, exist_ok=True)
    doc.write_text(text, encoding="utf-8")
    return doc
