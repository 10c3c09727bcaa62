"""The documentation site holds together without building it: every page is reachable from the table of
contents of ``docs/index.md``, and every relative link of the pages and of README points at a file that
exists (the docs build with ``-W`` checks the same, slower, in CI). The checks run on a made-up site too,
so that they can fail.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

TOCTREE_MD = re.compile(r"```\{toctree\}\n(.*?)```", re.S)
TOCTREE_RST = re.compile(r"\.\. toctree::\n((?:[ \t]+.*\n|\n)*)")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def pages(docs: Path) -> set[Path]:
    """Every Markdown and reStructuredText page of the site (the build folder left out)."""
    return {p for p in docs.rglob("*") if p.suffix in (".md", ".rst") and "_build" not in p.parts}


def toctree_entries(page: Path) -> list[Path]:
    """The pages a page's toctrees list, as paths (options and captions left out)."""
    text = page.read_text(encoding="utf-8")
    bodies = TOCTREE_MD.findall(text) + TOCTREE_RST.findall(text)
    out = []
    for body in bodies:
        for line in body.splitlines():
            entry = line.strip()
            if not entry or entry.startswith(":"):
                continue
            for suffix in (".md", ".rst"):
                p = (page.parent / entry).with_suffix(suffix)
                if p.exists():
                    out.append(p.resolve())
                    break
            else:
                out.append((page.parent / entry).resolve())
    return out


def unreachable(docs: Path) -> set[Path]:
    """Pages no toctree path from ``docs/index.md`` reaches."""
    seen, todo = set(), [(docs / "index.md").resolve()]
    while todo:
        p = todo.pop()
        if p in seen or not p.exists():
            continue
        seen.add(p)
        todo.extend(toctree_entries(p))
    return {p.resolve() for p in pages(docs)} - seen


def broken_links(files) -> list[str]:
    """Relative links (``[text](target)``) whose target file does not exist: ``"file: target"``."""
    out = []
    for f in files:
        for target in LINK.findall(f.read_text(encoding="utf-8")):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            path = target.split("#", 1)[0]
            if path and not (f.parent / path).exists():
                out.append(f"{f.relative_to(f.parents[1]) if len(f.parents) > 1 else f}: {target}")
    return out


def test_every_page_is_in_the_table_of_contents():
    missing = sorted(str(p.relative_to(DOCS)) for p in unreachable(DOCS))
    assert not missing, f"pages no toctree reaches: {missing}"


def test_every_relative_link_resolves():
    files = sorted(p for p in pages(DOCS) if p.suffix == ".md") + [ROOT / "README.md"]
    assert not broken_links(files)


def test_the_checks_find_a_lost_page_and_a_broken_link(tmp_path):
    docs = tmp_path / "docs"
    (docs / "sub").mkdir(parents=True)
    (docs / "index.md").write_text("# x\n\n```{toctree}\n:maxdepth: 1\n\nsub/a\n```\n[b](sub/b.md) [c](c.md)\n")
    (docs / "sub" / "a.md").write_text("# a\n[up](../index.md#top) [web](https://example.org)\n")
    (docs / "sub" / "b.md").write_text("# b\n")
    assert unreachable(docs) == {(docs / "sub" / "b.md").resolve()}
    assert [b.split(": ")[1] for b in broken_links(sorted(pages(docs)))] == ["c.md"]
