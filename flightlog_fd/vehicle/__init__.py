"""From the aircraft to a log file: `fdlog pull` over MAVLink (pymavlink).

- ports.py: the connection string, or the one autopilot on USB (pure functions);
- link.py: :class:`VehicleLink`, a ground station's link to one autopilot (heartbeats, identity);
- transfer.py: the MAVLink log protocol (LOG_REQUEST_LIST / LOG_ENTRY, LOG_REQUEST_DATA / LOG_DATA,
  LOG_REQUEST_END, LOG_ERASE) as PX4 and ArduPilot answer it, robust to loss and stalls;
- folder.py: a folder per vehicle, names that recognise a log pulled before, atomic files;
- pull.py: choose the logs and pull them (what the CLI calls).

Nothing here imports pymavlink until a link opens, so `fdlog --help` stays fast.
"""
