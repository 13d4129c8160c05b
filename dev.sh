#!/usr/bin/env bash
# Set up asmplan in ./.venv and run it, on a fresh Debian machine with Python 3.11.
#   bash dev.sh run  [asmplan run options]   # main job: the bundled seed workstation -> out/
#   bash dev.sh test [pytest options]        # the full test suite (CI runs this)
#   bash dev.sh bench [asmplan bench options]
# Installs what is missing: Debian's python3-venv and libosmesa6 (offscreen rendering) via
# apt-get (for `test` also chromium, in which the report is checked), and the Python packages
# pinned in constraints.txt. Re-runs skip what is done.
set -euo pipefail
cd "$(dirname "$0")"
here=$(pwd)
venv="$here/.venv"

log() { printf 'dev.sh: %s\n' "$*" >&2; }

as_root() {
    if [ "$(id -u)" = 0 ]; then "$@"
    elif command -v sudo >/dev/null 2>&1; then sudo "$@"
    else log "need root to run: $*"; exit 1
    fi
}

apt_updated=0
apt_install() {
    if [ "$apt_updated" = 0 ]; then
        as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null
        apt_updated=1
    fi
    log "installing Debian packages: $*"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}

pick_python() {
    for py in python3.11 python3.12 python3.13 python3; do
        if command -v "$py" >/dev/null 2>&1 &&
           "$py" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
            echo "$py"; return
        fi
    done
    log "Python >= 3.11 not found"; exit 1
}

setup() {
    # Offscreen rendering needs the OSMesa library (Debian: libosmesa6).
    if ! ldconfig -p 2>/dev/null | grep -q 'libOSMesa\.so'; then
        apt_install libosmesa6
    fi
    if [ ! -x "$venv/bin/python" ]; then
        py=$(pick_python)
        if ! "$py" -m venv "$venv" >/dev/null 2>&1; then
            rm -rf "$venv"
            apt_install "$(basename "$py")-venv" || apt_install python3-venv
            "$py" -m venv "$venv"
        fi
    fi
    # Reinstall only when the dependency files changed.
    stamp="$venv/.asmplan-installed"
    want=$(cat pyproject.toml constraints.txt | sha256sum | cut -d' ' -f1)
    if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
        log "installing Python packages into .venv (pinned by constraints.txt)"
        "$venv/bin/python" -m pip install -q --upgrade pip >/dev/null
        "$venv/bin/python" -m pip install -q -c constraints.txt -e ".[dev]"
        echo "$want" > "$stamp"
    fi
    # The package is installed editable, so pip compiles no bytecode for it, and where
    # PYTHONDONTWRITEBYTECODE is set Python never caches it: compile it here (each `asmplan`
    # run then saves ~0.1 s of compiling its own modules; unchanged files are skipped).
    "$venv/bin/python" -m compileall -q knowledge parts planner sim report asmplan examples bench >/dev/null
}

# OpenBLAS (under numpy and scipy) picks its kernels by CPU, and they round differently in
# the last bit: a plan, and through it a knife-edge verdict, can differ between machines
# (docs/physics.md, Known limits). Use the SkylakeX kernels where the CPU has AVX-512 (the
# goldens' and the benchmarks' kernels; tests/conftest.py does the same), replacing a kernel
# the environment sets; elsewhere leave OpenBLAS its choice.
pin_blas_kernels() {
    local flags
    flags=$(grep -m1 '^flags' /proc/cpuinfo 2>/dev/null || true)
    for f in avx512f avx512cd avx512bw avx512dq avx512vl; do
        case " $flags " in *" $f "*) ;; *) return 0 ;; esac
    done
    export OPENBLAS_CORETYPE=SkylakeX
}

cmd=${1:-run}
[ $# -gt 0 ] && shift
pin_blas_kernels
case "$cmd" in
    setup) setup ;;
    run)
        setup
        exec "$venv/bin/asmplan" run "$@" ;;
    test)
        setup
        # The report tests open report.html in a real headless browser (Debian's chromium).
        if ! command -v chromium >/dev/null 2>&1; then
            if [ "$(id -u)" = 0 ] || command -v sudo >/dev/null 2>&1; then
                apt_install chromium || log "chromium not installed: the browser tests will be skipped"
            else
                log "chromium not installed (needs root): the browser tests will be skipped"
            fi
        fi
        # One pytest worker per core (pytest-xdist; ASMPLAN_TEST_WORKERS=0 runs in one process),
        # each test file on one worker (--dist loadfile: a file's module-scope fixtures built once).
        exec "$venv/bin/python" -m pytest -n "${ASMPLAN_TEST_WORKERS:-auto}" --dist loadfile "$@" ;;
    bench)
        setup
        exec "$venv/bin/asmplan" bench "$@" ;;
    *) log "unknown command '$cmd'; expected run, test, bench or setup"; exit 2 ;;
esac
