#!/usr/bin/env bash
# Set up everything fallgen needs on a fresh Debian machine, idempotently:
#   - Debian GL libraries for headless MuJoCo rendering (EGL / OSMesa), when missing;
#   - a virtualenv in .venv with fallgen installed (editable) with its test and learn extras
#     (the learn extra's tests, Stable-Baselines3 on fallgen.env.wrappers, always run).
# Usage: scripts/setup.sh            (VENV=path and PYTHON=python3.11 override the defaults)
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}

apt_install() {
  local runner=()
  if [[ $(id -u) -ne 0 ]]; then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then runner=(sudo -n); else
      echo "setup: missing Debian packages: $* (not root and no sudo; install them yourself)" >&2
      return 0
    fi
  fi
  echo "setup: installing Debian packages: $*" >&2
  "${runner[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq >&2
  "${runner[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >&2
}

# Headless rendering: EGL (preferred) or OSMesa, both with Mesa's software rasteriser.
missing=()
have_lib() { ldconfig -p 2>/dev/null | grep -q "$1"; }
have_lib 'libEGL.so.1 ' || missing+=(libegl1)
have_lib 'libOpenGL.so.0 ' || missing+=(libopengl0)
have_lib 'libOSMesa.so' || missing+=(libosmesa6)
[[ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so || -e /usr/lib/x86_64-linux-gnu/dri/kms_swrast_dri.so || -e /usr/lib/aarch64-linux-gnu/dri/swrast_dri.so ]] || missing+=(libgl1-mesa-dri)
have_lib 'libsndfile.so.1 ' || true  # soundfile ships its own libsndfile wheel
if ((${#missing[@]})); then
  command -v apt-get >/dev/null 2>&1 && apt_install "${missing[@]}" \
    || echo "setup: no apt-get; headless rendering needs: ${missing[*]}" >&2
fi

if [[ ! -x $VENV/bin/python ]]; then
  if ! "$PYTHON" -m venv "$VENV" 2>/dev/null; then
    apt_install python3-venv
    "$PYTHON" -m venv "$VENV"
  fi
fi
stamp=$VENV/.fallgen-installed
want=$(cat pyproject.toml | sha256sum | cut -c1-16)
if [[ ! -f $stamp || $(cat "$stamp") != "$want" ]]; then
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check --upgrade pip >&2
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -e ".[test,learn]" >&2
  echo "$want" > "$stamp"
fi
echo "setup: ready ($VENV/bin/fallgen)" >&2
