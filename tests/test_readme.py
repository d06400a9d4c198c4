"""The README renders as written and the first `./run demo` says what it is doing (issue 15, item 22)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_readme_table_is_one_block_of_rows():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines):
        if line.startswith("|") and number > 0 and not lines[number - 1].startswith("|"):
            # a table starts here: header then separator; a later table row after prose would be a stray row
            assert number + 1 < len(lines) and re.match(r"^\|( *:?-+:? *\|)+$", lines[number + 1]), (
                f"README line {number + 1}: a table row after prose renders as stray text: {line[:60]}")


def test_layout_names_every_top_folder_in_its_table():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    layout = text[text.index("## Layout"):text.index("\n## ", text.index("## Layout") + 1)]
    rows = re.findall(r"^\| `([a-z]+)/` \|", layout, flags=re.M)
    assert rows == ["drivers", "analysis", "app", "tests", "benchmarks", "fixtures", "docs"]


def test_the_first_run_says_what_pip_is_doing_and_how_long_it_takes():
    script = (ROOT / "run").read_text(encoding="utf-8")
    install = script[script.index("ensure_venv()"):script.index("ensure_qt_runtime()")]
    says = " ".join(re.findall(r'say "([^"]*)"', install))
    assert "minutes" in says and "step 1/2" in says and "step 2/2" in says and "installed in" in says


def test_benchmark_table_is_one_short_line_per_benchmark_with_its_history_elsewhere():
    """A newcomer reads what each benchmark measures, its figure, goal and machine; the dated history is in
    benchmarks/README.md (issue 32, item 17)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Benchmarks"):]
    header = next(line for line in section.splitlines() if line.startswith("| script"))
    assert [c.strip() for c in header.strip("|").split("|")] == [
        "script", "what it measures", "current figure", "goal", "machine, date"]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    for row in rows:
        assert all(len(cell.split()) <= 20 for cell in row.strip("|").split(" | ")), f"a long cell: {row[:80]}"
    named = " ".join(rows)
    scripts = sorted(p.name for p in (ROOT / "benchmarks").glob("*.py") if p.name != "machine.py")
    assert [s for s in scripts if f"`{s}`" not in named] == []
    history = (ROOT / "benchmarks" / "README.md").read_text(encoding="utf-8")
    assert all(f"## `{s}`" in history for s in scripts)
    assert len(section.encode()) < 6_000  # (the table was 14 kB of dated history)
