#!/usr/bin/env bash
# Run the test suite in the project's venv (set up first if needed).
# Arguments go to pytest; with none, pytest.ini's defaults apply (testpaths = test,
# -m "not slow"); test/conftest.py runs every test process with one BLAS/OpenMP thread
# (OMP_NUM_THREADS etc., unless set). Examples:
#   bash scripts/test.sh                                   # all but slow tests
#   bash scripts/test.sh test/integration/test_messages.py
#   bash scripts/test.sh -m slow                           # only the slow tests
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup_env.sh"
cd "$ROOT"
exec "$ROOT/.venv/bin/python" -m pytest "$@"
