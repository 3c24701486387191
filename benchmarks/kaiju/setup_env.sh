#!/usr/bin/env bash
# Build the side environment for the optional kaiju cross-check (.venv-kaiju).
#
# kaiju 1.4.1 is compiled against numpy 1.x, so it never goes into the project's .venv.
# Usage: benchmarks/kaiju/setup_env.sh [VENV_DIR]
#   KAIJU_WHEELS=DIR   folder holding an sdss_kaiju-*.whl (installed with --no-deps);
#                      without it, sdss-kaiju is installed from the package index
#                      (its sdist downloads C++ sources while building: needs network).
#   PY=python3         interpreter the environment is made from (3.11 for the wheel).
set -euo pipefail
VENV="${1:-.venv-kaiju}"
PY="${PY:-python3}"
if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c "import kaiju, coordio" 2>/dev/null; then
    echo "$VENV: kaiju already installed"; exit 0
fi
"$PY" -m venv "$VENV"
"$VENV/bin/pip" install -q "numpy<2" "shapely<2" matplotlib descartes "pybind11<3" \
    fitsio psutil seaborn simplification pandas scipy sdss-coordio
if [ -n "${KAIJU_WHEELS:-}" ]; then
    wheel=$(ls "$KAIJU_WHEELS"/sdss_kaiju-*.whl | sort | tail -n 1)
    "$VENV/bin/pip" install -q --no-deps "$wheel"
else
    "$VENV/bin/pip" install -q --no-deps sdss-kaiju
fi
"$VENV/bin/python" -c "from kaiju.robotGrid import RobotGridNominal; print('kaiju robots:', len(RobotGridNominal().robotDict))"
