"""Scenes built with code: grid sheets and the demo (``scenes.builders``), collision scenes
(``scenes.collision``), hard GIA scenes (``scenes.gia``); ``scenes/generate.py`` writes the demo
and the analytic scenes to disk. Used by the tests and the benchmarks; never by ``weft``."""
