#!/bin/sh
# gasfilm from another checkout of the project ($GASFILM_TREE, e.g. a clean `git worktree add --detach DIR COMMIT`)
# with the Python environment of /work/main/.venv (or $GASFILM_PYTHON): the editable install's mapping is pointed at
# the checkout before anything of gasfilm is imported, and the diagnosis is checked to come from it.
: "${GASFILM_TREE:?set GASFILM_TREE to the checkout to run}"
exec "${GASFILM_PYTHON:-/work/main/.venv/bin/python}" -c "
import importlib, os, sys
tree = os.path.abspath(os.environ['GASFILM_TREE'])
finder = next(importlib.import_module(m) for m in list(sys.modules) if m.startswith('__editable__') and m.endswith('_finder'))
finder.MAPPING.update({f'gasfilm.{p}': os.path.join(tree, p) for p in ('analysis', 'app', 'drivers')})
import gasfilm.analysis.diagnosis
assert gasfilm.analysis.diagnosis.__file__.startswith(tree + os.sep), gasfilm.analysis.diagnosis.__file__
from gasfilm.app.cli import main
sys.argv[0] = 'gasfilm'
sys.exit(main())
" "$@"
