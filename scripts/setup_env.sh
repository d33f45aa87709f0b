#!/usr/bin/env bash
# Create or refresh the project's virtual environment in <repo>/.venv:
#   pinned requirements (ROS 2 Kilted wheels, torch, ...), the pier_monitor_msgs interface
#   package built from msg_defs/ and installed into the venv prefix, and pier_monitor itself
#   (editable). Nothing has to be sourced afterwards: use .venv/bin/python.
#
# Idempotent: a stamp in .venv records a hash of the inputs; when they have not changed a
# run returns at once. Options: --force (redo everything), -h/--help.
# Environment: PYTHON (interpreter to create the venv with, default python3; 3.11 or 3.12).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PY="$VENV/bin/python"
STAMP="$VENV/.pier_monitor_setup.sha256"
PYTHON="${PYTHON:-python3}"

say() { printf '[setup_env] %s\n' "$*"; }
die() { printf '[setup_env] ERROR: %s\n' "$*" >&2; exit 1; }
trap 'printf "[setup_env] ERROR: command failed (exit %s, line %s): %s\n" "$?" "$LINENO" "$BASH_COMMAND" >&2' ERR

force=0
for arg in "$@"; do
    case "$arg" in
        --force) force=1 ;;
        -h|--help) sed -n '2,9p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) die "unknown option: $arg (try --help)" ;;
    esac
done

cd "$ROOT"

# One setup at a time (e.g. two test runs started together): lock this script's own file.
if command -v flock >/dev/null 2>&1; then
    exec 9<"${BASH_SOURCE[0]}"
    flock 9
fi

# Everything that determines the environment's content. Data files (package.xml, resource/,
# config/*.yaml) are symlinked into the venv, so only the names of config files count.
inputs_hash() {
    {
        "$PYTHON" -c 'import sys; print(sys.version)'
        find requirements.txt setup.py setup.cfg msg_defs \
            scripts/setup_env.sh scripts/build_msgs.py scripts/link_data_files.py \
            -type f -not -path '*/__pycache__/*' -print0 | sort -z | xargs -0 sha256sum
        if [ -d config ]; then find config -name '*.yaml' -type f | sort; fi
    } | sha256sum | cut -d' ' -f1
}

"$PYTHON" -c 'import sys' 2>/dev/null || die "'$PYTHON' not found: install Python 3.11 or 3.12, or set PYTHON"
hash="$(inputs_hash)"
if [ "$force" -eq 0 ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$hash" ] \
        && "$PY" -c 'import sys' 2>/dev/null; then
    say "up to date ($VENV)"
    exit 0
fi

start=$SECONDS
"$PYTHON" -c 'import sys; sys.exit(not (3, 11) <= sys.version_info[:2] <= (3, 12))' \
    || die "$PYTHON is Python $("$PYTHON" -c 'import platform; print(platform.python_version())'); need 3.11 or 3.12 (ROS 2 Kilted wheels, numpy 2.4). Set PYTHON=..."
[ "$(uname -s)-$(uname -m)" = "Linux-x86_64" ] || die "the ROS 2 wheels exist for Linux x86_64 only"
command -v cmake >/dev/null 2>&1 || die "cmake not found (needed to build msg_defs/)"
command -v c++ >/dev/null 2>&1 || die "no C++ compiler (c++) found (needed to build msg_defs/)"

rm -f "$STAMP"
# (Re)create the venv when it is missing, broken, or made by another interpreter.
version='import sys; print(sys.version)'
if [ "$("$PY" -c "$version" 2>/dev/null)" != "$("$PYTHON" -c "$version")" ]; then
    say "creating $VENV with $("$PYTHON" -c 'import sys; print(sys.executable)')"
    "$PYTHON" -m venv --clear "$VENV" || die "python -m venv failed (on Debian/Ubuntu: apt install python3-venv)"
fi

say "upgrading pip"
"$PY" -m pip install -qq --disable-pip-version-check --upgrade pip

say "installing requirements.txt (first time: about a minute)"
"$PY" -m pip install -qq --disable-pip-version-check -r requirements.txt

say "building msg_defs/ (pier_monitor_msgs) into the venv"
"$PY" scripts/build_msgs.py

say "installing pier_monitor (editable)"
"$PY" -m pip install -qq --disable-pip-version-check --no-deps --no-build-isolation -e .
"$PY" scripts/link_data_files.py

say "checking imports"
"$PY" -c 'import importlib.util, rclpy, pier_monitor_msgs.msg, sensor_msgs.msg, diagnostic_msgs.msg, visualization_msgs.msg, rosbags, torch, ray
assert importlib.util.find_spec("pier_monitor"), "pier_monitor is not installed"' \
    || die "the environment was built but does not import; see the error above"

printf '%s\n' "$hash" > "$STAMP"
say "ready in $((SECONDS - start)) s: $VENV"
