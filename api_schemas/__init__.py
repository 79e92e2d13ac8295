"""Pydantic v2 models shared by the weft server, workers and CLI."""

from api_schemas.shot import (
    SHOT_FORMAT_VERSION,
    ArrayAsset,
    Body,
    ClothPiece,
    Environment,
    Features,
    Material,
    MeshSource,
    Pin,
    RestShape,
    Shot,
    SolverSettings,
    Wind,
)
from api_schemas.telemetry import TELEMETRY_COLUMNS, FrameTelemetry, FrameTelemetryJson

__all__ = [
    "SHOT_FORMAT_VERSION",
    "TELEMETRY_COLUMNS",
    "ArrayAsset",
    "Body",
    "ClothPiece",
    "Environment",
    "Features",
    "FrameTelemetry",
    "FrameTelemetryJson",
    "Material",
    "MeshSource",
    "Pin",
    "RestShape",
    "Shot",
    "SolverSettings",
    "Wind",
]
