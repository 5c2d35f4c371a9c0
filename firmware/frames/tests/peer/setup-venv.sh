#!/usr/bin/env bash
# Creates (idempotently) the Python virtual environment with the interoperability peers
# (cantools, python-can, pyserial, pyxcp) at <workspace>/target/py-peers, and installs the pinned
# requirements next to this script. Re-running it is cheap: pip only checks the pins.
# The Rust tests find the interpreter at <workspace>/target/py-peers/bin/python unless the
# environment variable MIL_PY names another one.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
workspace="$(cd "$here/../../../.." && pwd)"
venv="${MIL_PY_VENV:-$workspace/target/py-peers}"
python="${PYTHON:-python3}"

if [ ! -x "$venv/bin/python" ]; then
    echo "creating $venv" >&2
    "$python" -m venv "$venv"
fi
stamp="$venv/.requirements.sha256"
want="$(sha256sum "$here/requirements.txt" | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null || true)" != "$want" ]; then
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$here/requirements.txt"
    echo "$want" >"$stamp"
fi
"$venv/bin/python" -c 'import cantools, can, pyxcp; print("py-peers: cantools", cantools.__version__, "python-can", can.__version__, "pyxcp", pyxcp.__version__)'
