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
