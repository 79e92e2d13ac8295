"""Shared helpers: build scenes and simulations from shot documents in memory."""

from __future__ import annotations

import os

# OpenMP worker threads spin-wait between parallel regions; on a shared 2-core machine they
# steal the core the serial parts need (the collision tests ran ~10x slower). Set before the
# solver (libgomp) is loaded.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from weft import _solver
from weft.shot import parse_shot
from weft.solver_setup import Scene, build_setup, resolve_scene


def make_scene(document: dict[str, Any], base_dir: Path | None = None) -> Scene:
    return resolve_scene(parse_shot(document), base_dir or Path.cwd())


def make_sim(document: dict[str, Any], threads: int = 1) -> tuple[Scene, Any]:
    scene = make_scene(document)
    return scene, _solver.Simulation(build_setup(scene, threads))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)
