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
# wake-up (tens of microseconds); on 2 threads the 4k-vertex drape and the 10k sheet then ran
# 2.2-2.3x slower than with a spin. But a spinning thread also holds its core while a process
# beside weft wants it: with one busy process on a 2-core machine, 20,000 spins (this default
# until 2026-11-27) made the dress 4x and the drape 6x slower than no spin at all. 1,000 spins
# cost nothing measurable when the machine is idle and a quarter to a third of 20,000's time
# when it is not (`python -m bench.omp_wait`, docs/linear-system.md).
OPENMP_SPIN_COUNT = 1000
_os.environ.setdefault("GOMP_SPINCOUNT", str(OPENMP_SPIN_COUNT))
