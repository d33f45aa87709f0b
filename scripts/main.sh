#!/usr/bin/env bash
# Run the pier_monitor demo in the project's venv (set up first if needed).
# Arguments go to `pier-monitor demo`; outputs are written relative to the repository root.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup_env.sh"
cd "$ROOT"
exec "$ROOT/.venv/bin/pier-monitor" demo "$@"
