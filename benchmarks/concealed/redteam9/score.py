"""Score ``gasfilm diagnose`` on the round-9 red-team world (run generate.py first).

Round 3's scorer (benchmarks/concealed/redteam3/score.py) scores it, so that the rounds are scored alike (with round
4's additions there: ``refusal_ok``, ``structure-mode`` → ``extra-mode``). The commands per case and the scoring
rules are in that file's docstring: per case, as a user would,

    gasfilm diagnose out/redteam9/<case>.uff --mass 25.05 --json --out out/redteam9/diagnoses/<case> --overwrite

(every case of this round is diagnosed with the mass alone; ``nominal-rig.toml`` is written for a reader who wants
to try the nominal spec).

    python benchmarks/concealed/redteam9/score.py [--data out/redteam9] [--only CASE ...] [--label NAME]

Run it with the Python of the environment whose ``gasfilm`` is to be scored (``/work/main/.venv/bin/python``): the
scorer runs the ``gasfilm`` beside that interpreter.
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
    sys.exit(round3.main(default_data=Path("out/redteam9")))
