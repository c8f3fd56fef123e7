"""`fdlog serve`: the fleet's web page (upload logs, background diagnosis, per-airframe history).

Modules: :mod:`.app` (FastAPI routes and pages), the store is
:mod:`flightlog_fd.store` (flights, jobs, airframes, shared with `fdlog diagnose --db` and
`fdlog history`), :mod:`.worker` (the job runner and
what runs in its worker processes), :mod:`.security` (tokens, sessions, CSRF). Needs the
``[serve]`` extra; nothing here is imported by the other commands.
"""
