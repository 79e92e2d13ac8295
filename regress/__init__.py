"""`weft regress`: the regression scenes (`scenes/regression/`) run by the service and judged
against their references (issue 14).

- ``regress.runs``: a scene's shot written to disk, run in this process or read from a cache
- ``regress.references``: the converged reference runs (`weft regress --update-references`)
- ``regress.judge``: metrics of a run against its reference and thresholds
- ``regress.report``: Markdown, JUnit XML and JSON reports
- ``regress.service``: submit scenes to a running service, follow them, fetch their caches
"""
