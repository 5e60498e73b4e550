"""The README's Python code blocks run as written (a user copies them first), and its command table lists
every ``graphnav`` subcommand."""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", README.read_text(), flags=re.S | re.M)


def run_block(code: str, name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")              # the alignment's notes are what a user sees too
        exec(compile(code, name, "exec"), {"__name__": "__readme__"})


def test_readme_navigator_loop_runs_and_stays_healthy(tmp_path, monkeypatch, capsys):
    blocks = [b for b in python_blocks() if "Navigator(" in b and "add_imu" in b]
    assert len(blocks) == 1
    monkeypatch.chdir(tmp_path)
    run_block(blocks[0], "README.md: the Navigator loop")
    out = capsys.readouterr().out
    # 400 s at 1 Hz pings: one estimate per ping once aligned and carried back to the start
    n = int(re.search(r"(\d+) estimates; last at t = ([\d.]+) s", out).group(1))
    assert n >= 390 and out.splitlines()[0].endswith(", ok")


@pytest.mark.parametrize("index", [i for i, b in enumerate(python_blocks()) if "add_imu" not in b])
def test_readme_python_block_runs(index, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    run_block(python_blocks()[index], f"README.md python block {index + 1}")
    assert capsys.readouterr().out.strip(), "every README block prints what it shows"


def test_readme_lists_every_subcommand():
    from graphnav.cli import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    table = README.read_text()
    missing = [name for name in sub.choices if f"| `graphnav {name}` |" not in table]
    assert not missing, f"README command table lacks {missing}"


DOCS = README.parent / "docs"


def test_docs_index_lists_every_decision_page():
    index = (DOCS / "README.md").read_text()
    missing = [p.name for p in sorted((DOCS / "decisions").glob("*.md")) if f"(decisions/{p.name})" not in index]
    assert not missing, f"docs/README.md does not list {missing}"


def without_code(text: str) -> str:
    """The page without its fenced code blocks: a link or a ``#`` line in code is neither a link nor a heading."""
    return re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)


@pytest.mark.parametrize("page", ["README.md", "docs/README.md"])
def test_relative_links_resolve(page):
    path = README.parent / page
    text = without_code(path.read_text())
    links = re.findall(r"\]\(([^)#:]+)\)", text)
    assert links
    broken = [link for link in links if not (path.parent / link).exists()]
    assert not broken, f"{page}: links to missing files {broken}"


def heading_anchors(text: str) -> set[str]:
    """The anchors a Markdown renderer such as GitHub's gives the page's headings: lower case, punctuation
    dropped but for hyphens and underscores, spaces turned into hyphens, a repeated one numbered."""
    anchors, seen = set(), {}
    for heading in re.findall(r"^#{1,6} (.+)$", text, flags=re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        anchors.add(f"{slug}-{n}" if n else slug)
    return anchors


def test_heading_anchors_follow_the_renderer():
    text = "# A page\n## Protocol (`x.y`)\n## Out-of-fold table, A-KIT (m/s; gain = 1 - a/b)\n## Reading\n## Reading\n"
    assert heading_anchors(text) == {"a-page", "protocol-xy", "out-of-fold-table-a-kit-ms-gain--1---ab", "reading",
                                     "reading-1"}


@pytest.mark.parametrize("page", sorted(p.name for p in (DOCS / "decisions").glob("*.md")))
def test_links_within_a_decision_page_land_on_a_heading(page):
    text = without_code((DOCS / "decisions" / page).read_text())
    targets = set(re.findall(r"\]\(#([^)]+)\)", text))
    missing = targets - heading_anchors(text)
    assert not missing, f"docs/decisions/{page}: links to no heading {sorted(missing)}"
