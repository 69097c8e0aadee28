#!/usr/bin/env bash
# streamseg developer entry point: `bash dev.sh demo` or `bash dev.sh test`.
# Creates ./.venv on first use (Python >= 3.10 and pip are all it needs) and keeps it in step
# with pyproject.toml.
set -euo pipefail
cd "$(dirname "$0")"
PY=${PYTHON:-python3}

ensure_env() {  # $1 = extras, e.g. "plot" or "test,plot,dev"
    local extras=$1 stamp=".venv/.dev-stamp-${1//,/-}"
    if [ ! -x .venv/bin/python ]; then
        "$PY" -m venv .venv
    fi
    if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
        .venv/bin/python -m pip install --quiet --upgrade pip
        .venv/bin/python -m pip install --quiet -e ".[${extras}]"
        touch "$stamp"
    fi
}

case "${1:-}" in
    demo)
        ensure_env plot,view
        shift
        exec .venv/bin/streamseg demo "$@"
        ;;
    test)
        ensure_env test,plot,dev,docs
        shift
        .venv/bin/ruff check .
        .venv/bin/ruff format --check --quiet .
        # the documentation site, strictly: a broken link or reference fails the run
        NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --quiet
        set +e
        .venv/bin/python -m pytest -q "$@"
        rc=$?
        set -e
        # pytest exits 5 when it collected nothing: that is a failure here, not a pass.
        exit $rc
        ;;
    *)
        echo "usage: bash dev.sh demo | test [pytest args]" >&2
        exit 2
        ;;
esac
