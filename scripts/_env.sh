# shellcheck shell=bash
# scripts/_env.sh -- sourced by scripts/test and scripts/reproduce; not run directly.
#
# Makes sure <repo>/.venv exists and matches environment.txt, puts it first on
# PATH, and exports run-time defaults. Nothing is installed outside .venv.
#
#   * .venv missing or broken        -> created with `python3 -m venv`, then
#                                       `pip install -r environment.txt`
#   * environment.txt changed since  -> `pip install -r environment.txt` into
#     the last build                    the existing .venv (packages that were
#                                       dropped from the file stay installed;
#                                       `rm -rf .venv` for a clean rebuild)
#   * up to date                     -> nothing to do (a hash comparison)
#
# The repository itself is installed editable into .venv (`pip install -e .`, no
# build isolation, so no network: setuptools and wheel come from environment.txt);
# `import lab` and the `lab` command then work from any directory, e.g. notebook
# kernels started in notebooks/.
#
# The last built state is a SHA-256 of environment.txt and pyproject.toml kept in
# .venv/.environment.sha256. Set LAB_PYTHON to use another interpreter than
# python3 for creating the venv (the pins are for Python 3.11).

LAB_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export LAB_ROOT

_lab_sha256() {
    if command -v sha256sum >/dev/null 2>&1; then
        sha256sum "$1" | cut -d' ' -f1
    else
        shasum -a 256 "$1" | cut -d' ' -f1
    fi
}

_lab_venv_ok() {
    # usable interpreter and a stamp that matches environment.txt
    [ -x "$1/bin/python" ] && "$1/bin/python" -c '' >/dev/null 2>&1 &&
        [ "$(cat "$1/.environment.sha256" 2>/dev/null)" = "$2" ]
}

_lab_bootstrap() {
    local venv="$LAB_ROOT/.venv" req="$LAB_ROOT/environment.txt"
    local py="${LAB_PYTHON:-python3}" want site
    want="$(_lab_sha256 "$req")-$(_lab_sha256 "$LAB_ROOT/pyproject.toml")" || return 1
    _lab_venv_ok "$venv" "$want" && return 0

    # Serialise concurrent bootstraps (two scripts started at once) by locking
    # environment.txt itself; the second one re-checks after the first is done.
    if command -v flock >/dev/null 2>&1; then
        exec 9<"$req"
        flock 9
        if _lab_venv_ok "$venv" "$want"; then
            exec 9<&-
            return 0
        fi
    fi

    if ! "$py" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
        echo "lab: warning: environment.txt is pinned for Python 3.11; '$py' is $("$py" --version 2>&1)" >&2
    fi

    if ! { [ -x "$venv/bin/python" ] && "$venv/bin/python" -c '' >/dev/null 2>&1; }; then
        echo "lab: creating .venv with $("$py" --version 2>&1) (first run: a few minutes)" >&2
        "$py" -m venv --clear "$venv" || return 1
    fi
    echo "lab: installing environment.txt into .venv" >&2
    # (pip's notes about configured local index folders that lack a package
    # are noise here and are filtered out)
    "$venv/bin/python" -m pip install --quiet --progress-bar off -r "$req" 2>&1 |
        grep -v "^WARNING: Location 'file:.*' is ignored" >&2
    [ "${PIPESTATUS[0]}" -eq 0 ] || return 1

    # Jupyter kernel spec inside the venv only (<venv>/share/jupyter/kernels).
    "$venv/bin/python" -m ipykernel install --sys-prefix --name lab-venv \
        --display-name "Python 3 (lab .venv)" >/dev/null || return 1

    # The repository, editable (replaces the lab_repo_root.pth of older .venvs).
    site="$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')" || return 1
    rm -f "$site/lab_repo_root.pth"
    "$venv/bin/python" -m pip install --quiet --no-deps --no-build-isolation -e "$LAB_ROOT" >&2 || return 1

    printf '%s\n' "$want" >"$venv/.environment.sha256" || return 1
    echo "lab: .venv is ready" >&2
    # (a redirection on `exec` itself would apply to the shell for good: close fd 9 only)
    { exec 9<&-; } 2>/dev/null || true
    return 0
}

_lab_bootstrap || { echo "lab: failed to set up .venv from environment.txt" >&2; return 1 2>/dev/null || exit 1; }

export VIRTUAL_ENV="$LAB_ROOT/.venv"
export PATH="$VIRTUAL_ENV/bin:$PATH"
unset PYTHONHOME

# One thread per process: the machines have 2 cores and parallelism comes from
# worker processes (pytest-xdist, joblib). Override by setting them beforehand.
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
export MKL_NUM_THREADS="${MKL_NUM_THREADS:-1}"
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
# Headless plotting and deterministic hashing.
export MPLBACKEND=Agg
export PYTHONHASHSEED=0
# Python's bytecode cache, even where PYTHONDONTWRITEBYTECODE is set (some images set it): else
# every process -- each test worker, notebook kernel, joblib worker and `python -m lab` call --
# compiles lab's modules again. The .pyc files go into __pycache__/ beside the sources, which
# git ignores (numba keeps its cache of the FEM kernels there too).
unset PYTHONDONTWRITEBYTECODE
