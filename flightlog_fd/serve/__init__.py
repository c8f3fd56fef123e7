"""`fdlog serve`: the fleet's web page (upload logs, background diagnosis, per-airframe history).

Modules: :mod:`.app` (FastAPI routes and pages), :mod:`.store` (flights, jobs, airframes in
SQLite or PostgreSQL through :mod:`flightlog_fd.database`), :mod:`.worker` (the job runner and
what runs in its worker processes), :mod:`.security` (tokens, sessions, CSRF). Needs the
``[serve]`` extra; nothing here is imported by the other commands.
"""
