"""Serve the API: ``python -m server --host 127.0.0.1 --port 8421 [--local]``.

Settings come from WEFT_* environment variables (``weft.jobstore.ServiceSettings``). ``--local`` turns off
API keys and is refused unless the host is a loopback address.
"""

from __future__ import annotations

import argparse
import ipaddress
import os
import sys

import uvicorn


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m server")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8421)
    parser.add_argument("--local", action="store_true", help="no API keys; loopback only")
    parser.add_argument("--processes", type=int, default=1, help="uvicorn worker processes (the API is stateless)")
    args = parser.parse_args()
    if args.local:
        try:
            loopback = ipaddress.ip_address(args.host).is_loopback
        except ValueError:
            loopback = args.host == "localhost"
        if not loopback:
            sys.exit("--local needs a loopback host (127.0.0.1 or ::1)")
        os.environ["WEFT_LOCAL"] = "1"
    elif not (os.environ.get("WEFT_API_KEYS") or os.environ.get("WEFT_API_KEYS_FILE")):
        sys.exit("set WEFT_API_KEYS or WEFT_API_KEYS_FILE (or use --local on a loopback host)")
    uvicorn.run(
        "server.main:create_app", factory=True, host=args.host, port=args.port, workers=args.processes,
        log_level=os.environ.get("WEFT_LOG_LEVEL", "warning").lower(),
        # Open event streams end on their own within seconds; never wait on a client for ever.
        timeout_graceful_shutdown=10,
    )


if __name__ == "__main__":
    main()
