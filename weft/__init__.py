"""weft: implicit cloth simulation for film and animation pipelines."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("weft")
except PackageNotFoundError:  # running from a source tree without an install
    __version__ = "0.0.0+source"

# OpenMP threads that wait at a barrier spin a while, then sleep, unless the user chose
# otherwise. Read once, when weft._solver (libgomp) is first loaded.
import os as _os

_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# The spin: with PASSIVE alone libgomp spins 0 times and every barrier is a futex wake-up; the
# drape then ran 2.1x slower on 2 threads than with a spin. The solver opens about 360 parallel
# regions per substep, and a spin that outlasts the serial gaps between them saves most of the
# wake-ups: on an idle 2-core machine 10,000 spins (about 0.1 ms here) ran the 4k-vertex drape
# and the standing dress in 0.78x and 0.86x the time of 1,000 (the default from 2026-11-27 to
# 2026-12-08). A spinning thread also holds its core while a process beside weft wants it:
# beside one busy process 10,000 spins alone made both 2.4-2.5x slower than 1,000. The thread
# governor (weft/thread_governor.py) bounds that to a couple of frames: then a crowded run steps
# down to fewer threads, which wait for nothing, and runs 0.89-0.94x the old default's time
# (`python -m bench.omp_wait`, docs/linear-system.md).
OPENMP_SPIN_COUNT = 10000
_os.environ.setdefault("GOMP_SPINCOUNT", str(OPENMP_SPIN_COUNT))
