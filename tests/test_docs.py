"""The docs and the code cite only what exists, and carry no development history."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).parent.parent
SOURCES = [p for p in ROOT.rglob("*") if p.suffix in (".py", ".md", ".toml") and ".venv" not in p.parts
           and "out" not in p.parts and ".git" not in p.parts]
CITED = re.compile(r"(?<![\w/.])((?:bench/results|docs|experiments|assets|examples)/[\w./*-]*[\w*])")


def test_every_cited_path_exists() -> None:
    """Every path under bench/results, docs, experiments, assets or examples named in a source or
    doc file exists in the tree (a docstring once cited a result file that was never written).
    Paths inside experiments/README.md's index name files at past commits, so that index is not
    checked; nor are paths with wildcards or placeholders."""
    missing = []
    for path in SOURCES:
        if path == ROOT / "experiments" / "README.md":
            continue
        for cited in CITED.findall(path.read_text(errors="replace")):
            if any(c in cited for c in "*<>{}") or cited.endswith((".", "/")) or re.search(r"/[A-Z]+\b", cited):
                continue
            if not (ROOT / cited).exists():
                missing.append(f"{path.relative_to(ROOT)}: {cited}")
    assert not missing, missing


HISTORY = re.compile(r"20[0-9]{2}-[01][0-9]-[0-3][0-9]|\bissue [0-9]|\btoday\b|\b(?:first|second|third|fourth|fifth|"
                     r"sixth|seventh|eighth|ninth|tenth|eleventh) session\b", re.IGNORECASE)


def test_no_development_history_in_code_tests_or_docs() -> None:
    """No calendar dates, issue numbers, words for the present day or numbered work periods outside
    the experiments' manifests and results (history lives in git and in manifests)."""
    found = []
    for path in SOURCES:
        if "experiments" in path.parts:
            continue
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if HISTORY.search(line):
                found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:80]}")
    assert not found, found
