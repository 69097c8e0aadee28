#!/usr/bin/env bash
# Run benchmarks/peers.py in its own venv (.venv-peers): claspy 0.2.8 pins older numpy, numba
# and scikit-learn than streamseg's main environment, so the peers never downgrade .venv.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv-peers/bin/python ]; then
    "$PY" -m venv .venv-peers
fi
if [ ! -f .venv-peers/.stamp ] || [ pyproject.toml -nt .venv-peers/.stamp ]; then
    .venv-peers/bin/python -m pip install --quiet --upgrade pip
    .venv-peers/bin/python -m pip install --quiet -e ".[peers,plot]"
    touch .venv-peers/.stamp
fi
exec .venv-peers/bin/python benchmarks/peers.py "$@"
