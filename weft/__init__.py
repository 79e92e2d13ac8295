"""weft: implicit cloth simulation for film and animation pipelines."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("weft")
except PackageNotFoundError:  # running from a source tree without an install
    __version__ = "0.0.0+source"

# OpenMP threads that wait at a barrier sleep instead of spinning unless the user chose
# otherwise. The solver's CG has three barriers per iteration; on a machine shared with other
# jobs (farm nodes, CI) spinning threads steal the core from the very thread they wait for and a
# solve can take 10-30x longer. Read once, when weft._solver (libgomp) is first loaded.
import os as _os

_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# ...after a short spin: with PASSIVE alone libgomp spins 0 times and every barrier is a futex
# wake-up (tens of microseconds); CG on a 4k-vertex drape then ran slower on 2 threads than on 1.
# 20,000 spins (some microseconds) let threads that arrive together pass at once and still
# sleep soon on a busy machine (`python -m bench.contact --scenes drape_sphere`, 2 cores:
# 0.27 s/frame passive, 0.22 with the spin).
_os.environ.setdefault("GOMP_SPINCOUNT", "20000")
