"""Score ``gasfilm diagnose`` on the round-4 red-team world (run generate.py first).

Round 3's scorer (benchmarks/concealed/redteam3/score.py) scores it, so that the rounds are scored alike; round 4
added to it ``refusal_ok`` (a clean one-line refusal, exit status != 0 and no traceback,
counts as honest not-explained where the key says so) and maps ``structure-mode`` onto ``extra-mode``.

Per case, exactly as an engineer would run it (the ``gasfilm`` beside this Python, i.e. the worktree's .venv):

    gasfilm diagnose <case>.uff --mass 25.05 --json --out <dir> --overwrite            (key "cli": "mass")
    gasfilm diagnose <case>.uff --rig nominal-rig.toml --json --out <dir> --overwrite   (key "cli": "rig")

The scoring rules are those of ``benchmarks/concealed/redteam/score.py`` (first that applies):
- **error**: the command failed or timed out, or the key is missing or newer than its UFF file;
- **must-not claimed**: a finding, or a quality note, that the key forbids;
- **false claim**: any finding on a control, or a finding outside the key's allowed names (``partial_ok`` names only
  beside a non-empty ``unexplained`` and a verdict "partly explained"/"not explained");
- **exact** / **acceptable**: the set of findings is one of the key's sets (an empty set needs the verdict
  ``consistent`` or ``parameters-only``; ``needs_alternative`` and ``empty_needs_recalibrated`` must hold);
- **honest not-explained**: not a control, the key allows it, verdict ``not explained``/``partly explained``,
  ``unexplained`` not empty, every finding allowed;
- **wrong**: anything else.
Right = exact, acceptable or honest not-explained. A traceback on stderr is reported whatever the outcome.

    python benchmarks/concealed/redteam4/score.py [--data out/redteam4] [--only CASE ...] [--label NAME]
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
    sys.exit(round3.main(default_data=Path("out/redteam4")))
