#!/usr/bin/env bash
# Sets up jostle on a fresh Debian machine: a virtual environment in .venv with jostle installed
# (editable, with the developer tools), and the Debian packages headless OpenGL needs.
# Safe to run again: it does only what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
VENV=.venv

if ! command -v "$PYTHON" >/dev/null 2>&1; then
  echo "setup: $PYTHON not found; install Python 3.11 or newer (Debian: apt-get install python3 python3-venv)" >&2
  exit 1
fi
if ! "$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)'; then
  echo "setup: jostle needs Python 3.11 or newer; $PYTHON is $("$PYTHON" -V 2>&1)" >&2
  exit 1
fi

# --- Debian packages for headless OpenGL (EGL + Mesa's llvmpipe) -------------------------------
missing=()
for lib in libEGL.so.1 libGL.so.1; do
  ldconfig -p 2>/dev/null | grep -q "$lib" || missing+=("$lib")
done
dri_ok=0
for d in /usr/lib/x86_64-linux-gnu/dri /usr/lib/aarch64-linux-gnu/dri /usr/lib/dri; do
  [ -e "$d/swrast_dri.so" ] && dri_ok=1
done
[ "$dri_ok" = 1 ] || missing+=("mesa-dri")
pkgs=""
[ ${#missing[@]} -gt 0 ] && pkgs="libegl1 libgl1 libgl1-mesa-dri"
# Xvfb: a virtual display, so the window and kiosk tests run on machines without a screen
command -v Xvfb >/dev/null 2>&1 || { missing+=("Xvfb"); pkgs="$pkgs xvfb"; }
if [ -n "$pkgs" ]; then
  echo "setup: missing ${missing[*]}; installing Debian packages:$pkgs"
  SUDO=""
  [ "$(id -u)" = 0 ] || SUDO="sudo -n"
  if command -v apt-get >/dev/null 2>&1 && $SUDO true 2>/dev/null; then
    $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $pkgs >/dev/null \
      || echo "setup: apt-get could not install$pkgs; headless rendering or the window tests may not run" >&2
  else
    echo "setup: cannot install them here (not root, no passwordless sudo, or no apt-get)." >&2
    echo "setup: ask an administrator to run: apt-get install$pkgs" >&2
    echo "setup: everything but headless rendering (and the window tests) will still work." >&2
  fi
fi

# --- virtual environment ------------------------------------------------------------------------
if [ ! -x "$VENV/bin/python" ]; then
  echo "setup: creating virtual environment in $VENV"
  "$PYTHON" -m venv "$VENV" || {
    echo "setup: could not create a virtual environment; on Debian: apt-get install python3-venv" >&2
    exit 1
  }
fi
stamp="$VENV/.jostle-installed"
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ constraints.txt -nt "$stamp" ]; then
  echo "setup: installing jostle and its dependencies into $VENV (first time takes a minute)"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  # constraints.txt: the versions the tests last passed with (`make lock`); without them a new release
  # of a dependency can change what a fresh machine runs
  if [ ! -f constraints.txt ] || ! "$VENV/bin/python" -m pip install -q -c constraints.txt -e '.[dev]'; then
    echo "setup: the tested versions (constraints.txt) are missing or do not install here; installing the" \
         "newest ones pyproject.toml allows instead (they may differ from what the tests last passed with)" >&2
    "$VENV/bin/python" -m pip install -q -e '.[dev]'
  fi
  touch "$stamp"
fi

# --- optional pose model (BlazePose, from the mediapipe wheel; never mediapipe itself) -----------
# Without network this only warns: the webcam observer then runs silhouette-only and says so.
"$VENV/bin/python" -m interaction.webcam.pose_models || true
