#!/usr/bin/env bash
# The Python package: `pip install ./python` (maturin's PEP 517 backend builds the pyo3 extension
# with cargo, release profile), the pytest suite in python/tests (against the host-sim binary:
# summary, trajectory, files, sweep, Controller, Parquet vs CSV with pyarrow), and the example
# notebook executed headless with nbclient. 11 min 40 s on the 2-core machine at load 13 (4.5 min CPU)
# with the extension and host-sim rebuilt in release; pytest 6 s and the notebook 10 s of it.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v pip3 >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-pip python3-venv
fi
pip_install() { pip3 install -q "$@" || pip3 install -q --break-system-packages "$@"; }
pip_install pytest nbclient nbformat ipykernel matplotlib pyarrow pandas
pip_install ./python
cargo build --release -p host-sim --bin host-sim
export HOST_SIM=$PWD/target/release/host-sim
(cd python/tests && python3 -m pytest -q)
python3 - <<'PY'
import time
import nbclient
import nbformat

t0 = time.time()
nb = nbformat.read("examples/example1.ipynb", as_version=4)
nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": "examples"}}).execute()
print(f"examples/example1.ipynb executed in {time.time() - t0:.1f} s")
PY
