#!/usr/bin/env bash
# The Python package: the locked dependencies of its tests and notebooks
# (python/requirements-lock.txt) and `pip install ./python` (maturin's PEP 517 backend builds the
# pyo3 extension with cargo, release profile) in a virtual environment, the pytest suite in
# python/tests (against the host-sim binary: summary, trajectory, files, sweep, Controller,
# errors through pickle and a process pool, Ctrl-C in a child process, Parquet vs CSV with
# pyarrow), and the example notebooks executed headless with nbclient. The Python part takes
# about 33 s on the 2-core machine (pytest 11 s; notebooks: example1 7 s, example2 7 s, study
# 8 s), against 16 s before the study and Example 2 notebooks; the rest is the release build of
# the extension and host-sim (34 min when cold at load 11, as measured on 2026-12-04; it shares
# the release artifacts of the stages before it in .ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
if ! python3 -m venv --help >/dev/null 2>&1 || ! python3 -c "import ensurepip" 2>/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-pip python3-venv
fi
venv=target/python-venv
python3 -m venv "$venv"
py=$PWD/$venv/bin/python
"$py" -m pip install -q -r python/requirements-lock.txt
"$py" -m pip install -q ./python
cargo build --release -p host-sim --bin host-sim
export HOST_SIM=$PWD/target/release/host-sim
echo "python.sh: installed and built in $((SECONDS - start)) s"
(cd python/tests && "$py" -m pytest -q)
"$py" - <<'PY'
import time
import nbclient
import nbformat

for name in ("example1", "example2", "study"):
    t0 = time.time()
    nb = nbformat.read(f"examples/{name}.ipynb", as_version=4)
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": "examples"}}).execute()
    print(f"examples/{name}.ipynb executed in {time.time() - t0:.1f} s")
PY
echo "python.sh: $((SECONDS - start)) s"
