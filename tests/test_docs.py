"""The front door and the docs: the README stays short and keeps the two commands CI runs; every link resolves;
docs/cli.md lists every flag of every installed command; every result file the docs name exists."""

from __future__ import annotations

import contextlib
import importlib
import io
import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
        *sorted((ROOT / "robots" / "adam_lite" / "policies").glob("*/README.md"))]
SCRIPTS = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
RESULTS = ROOT / "tools" / "results"


def test_the_readme_is_short_and_starts_with_the_two_commands():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 120
    first = text.split("```")[1].splitlines()[1:]   # the first code block, after its language tag
    assert first == ["bash tools/setup.sh && .venv/bin/cra-train",
                     "bash tools/setup.sh && .venv/bin/python -m pytest -q"]   # .ci/run executes line 2


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(doc):
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", doc.read_text())
    missing = [t for t in links if "://" not in t and not (doc.parent / t).exists()]
    assert not missing, missing


def _flags(name: str) -> set[str]:
    """The option flags of an installed command, from its --help (tyro or argparse)."""
    module, func = SCRIPTS[name].split(":")
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        getattr(importlib.import_module(module), func)(["--help"])
    flags = set()
    for line in out.getvalue().splitlines():
        s = line.replace("│", " ").strip()
        if s.startswith("-"):
            flags |= set(re.findall(r"--[a-z][a-z0-9-]*", re.split(r"\s{2,}", s)[0]))
    return flags - {"--help"}


def test_cli_doc_lists_every_command_and_flag():
    doc = (ROOT / "docs" / "cli.md").read_text()
    for name in SCRIPTS:
        assert f"## {name}\n" in doc, f"docs/cli.md has no section for {name} (run docs/make_cli.py)"
        section = doc.split(f"## {name}\n", 1)[1].split("\n## ", 1)[0]
        flags = _flags(name)
        assert flags or name == "cra-urdf2usd", name
        missing = sorted(f for f in flags if not re.search(re.escape(f) + r"(?![a-z0-9-])", section))
        assert not missing, f"docs/cli.md, {name}: {missing} (run docs/make_cli.py)"


def test_every_result_file_the_docs_name_exists():
    """A figure in the docs names its JSON; the names must be there (tools/results/ or a policy's folder)."""
    policies = ROOT / "robots" / "adam_lite" / "policies"
    known = {p.name for p in RESULTS.iterdir()} | {p.name for p in policies.glob("*/*")}
    stems = {n.split(".")[0] for n in known} | {p.name for p in policies.iterdir()}
    bad = {}
    for doc in DOCS:
        text = doc.read_text()
        named = set(re.findall(r"\b([a-z][a-z0-9_]*\.(?:json|csv))\b", text))
        named |= {m for m in re.findall(r"\b((?:ab|grid_cpu|probe|rough|walk|campaign|reach_rule)_[a-z0-9_]*[a-z0-9])\b",
                                        text)}
        missing = sorted(n for n in named if n not in known and n.split(".")[0] not in stems
                         and n not in ("config.json", "policy.json", "table.json", "eval.json", "eval.csv",
                                       "campaign.json", "bench_cuda.json"))
        if missing:
            bad[str(doc.relative_to(ROOT))] = missing
    assert not bad, bad


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_table_row_has_its_header_columns(doc):
    """A stray | in a cell (a flag's {a|b} choices) splits it and shifts the row; escape it as \\|."""
    lines, bad, width = doc.read_text().splitlines(), [], None
    for k, line in enumerate(lines):
        cells = len(re.split(r"(?<!\\)\|", line)) if line.startswith("|") else None
        if cells and k + 1 < len(lines) and set(lines[k + 1].replace(" ", "")) <= set("|-:") and width is None:
            width = cells
        elif cells is None:
            width = None
        elif width is not None and cells != width and not set(line.replace(" ", "")) <= set("|-:"):
            bad.append(k + 1)
    assert not bad, f"rows with the wrong column count at lines {bad}"
