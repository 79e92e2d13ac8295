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
