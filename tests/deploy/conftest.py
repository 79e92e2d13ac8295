from server.testing import redis_db, redis_server  # noqa: F401 (fixtures)
