"""Errors: every failure is a JSON body ``{"detail": ..., "errors": [{"field", "problem"}]}``
with its status code; never a 500 for a bad request."""

from __future__ import annotations

from typing import Any

import redis
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException

from api_schemas.service import ErrorResponse

# The error responses every route declares in the OpenAPI document.
ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 403, 404, 409, 413, 415, 422, 429, 503)
}


class ApiError(Exception):
    def __init__(self, status: int, detail: str, errors: list[dict[str, Any]] | None = None) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.errors = errors or []

    def __reduce__(self) -> tuple[Any, ...]:  # raised in a validation process, re-raised in the API
        return (ApiError, (self.status, self.detail, self.errors))


async def api_error(_: Request, exc: ApiError) -> JSONResponse:
    headers = {"WWW-Authenticate": "Bearer"} if exc.status == 401 else None
    return JSONResponse({"detail": exc.detail, "errors": exc.errors}, status_code=exc.status, headers=headers)


async def http_error(_: Request, exc: HTTPException) -> JSONResponse:
    return JSONResponse({"detail": str(exc.detail), "errors": []}, status_code=exc.status_code, headers=exc.headers)


async def validation_error(_: Request, exc: RequestValidationError) -> JSONResponse:
    errors = [{"field": ".".join(str(p) for p in e["loc"]), "problem": e["msg"]} for e in exc.errors()]
    detail = "; ".join(f"{e['field']}: {e['problem']}" for e in errors)
    return JSONResponse({"detail": f"invalid request: {detail}", "errors": errors}, status_code=422)


async def redis_down(_: Request, exc: redis.ConnectionError) -> JSONResponse:
    return JSONResponse({"detail": f"job store unavailable: {exc}", "errors": []}, status_code=503)


def install_error_handlers(app: FastAPI) -> None:
    app.add_exception_handler(ApiError, api_error)  # type: ignore[arg-type]
    # Starlette's HTTPException (FastAPI's derives from it): also the router's own 404 and 405.
    app.add_exception_handler(HTTPException, http_error)  # type: ignore[arg-type]
    app.add_exception_handler(RequestValidationError, validation_error)  # type: ignore[arg-type]
    app.add_exception_handler(redis.ConnectionError, redis_down)  # type: ignore[arg-type]
