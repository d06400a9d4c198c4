"""Score ``gasfilm diagnose`` on the round-8 red-team world (run generate.py first).

Round 3's scorer (benchmarks/concealed/redteam3/score.py) scores it, so that the rounds are scored alike (with round
4's additions there: ``refusal_ok``, ``structure-mode`` → ``extra-mode``). The commands per case and the scoring
rules are in that file's docstring: per case, as a user would,

    gasfilm diagnose out/redteam8/<case>.uff --mass 25.05 --json --out out/redteam8/diagnoses/<case> --overwrite
    gasfilm diagnose out/redteam8/<case>.uff --rig out/redteam8/nominal-rig.toml --json --out … --overwrite

    python benchmarks/concealed/redteam8/score.py [--data out/redteam8] [--only CASE ...] [--label NAME]
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("redteam3_score", HERE.parent / "redteam3" / "score.py")
round3 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(round3)

if __name__ == "__main__":
    sys.exit(round3.main(default_data=Path("out/redteam8")))
