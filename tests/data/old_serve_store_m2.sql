-- A serve store as fdlog 0.1 (main 81f2534) wrote it (migrations 1-2): the two sample logs uploaded
-- and diagnosed (windows cut to 3, no plot), one airframe named 'X500 #3'; sqlite3's iterdump.
BEGIN TRANSACTION;
CREATE TABLE airframe (
    key            TEXT PRIMARY KEY,   -- identity from the log (sys_uuid...) or log:<sha12> for a log without one
    source         TEXT NOT NULL,      -- where the key came from: sys_uuid, board_uid, BRD_SERIAL_NUM, ..., none
    name           TEXT,               -- the operator's name for it (NULL: show the key)
    merged_into    TEXT,               -- the operator merged it into this airframe (NULL: itself)
    profile_path   TEXT,               -- calibration profile its later flights are diagnosed with
    profile_sha256 TEXT,
    created_at     TEXT NOT NULL
);
INSERT INTO "airframe" VALUES('sim-12-0','sys_uuid','X500 #3',NULL,NULL,NULL,'2026-11-25T21:01:58.031Z');
INSERT INTO "airframe" VALUES('log:4e700cdc05a7','none',NULL,NULL,NULL,NULL,'2026-11-25T21:02:00.756Z');
CREATE TABLE finding (
    flight_id   BIGINT NOT NULL REFERENCES flight(id) ON DELETE CASCADE,
    analyzer    TEXT NOT NULL,     -- the evidence source (model, commands, effectiveness...)
    motor       INTEGER,
    name        TEXT NOT NULL,
    value       REAL,
    unit        TEXT,
    interval_lo REAL,
    interval_hi REAL,
    baseline    REAL,
    llr         REAL,            -- log-likelihood ratio for "this rotor lost thrust", nats
    text        TEXT
);
INSERT INTO "finding" VALUES(1,'model',1,'vote',0.6305,'',NULL,NULL,NULL,6.3916,'0.63');
INSERT INTO "finding" VALUES(1,'model',2,'vote',0.1672,'',NULL,NULL,NULL,0.7271,'0.17');
INSERT INTO "finding" VALUES(1,'model',3,'vote',0.032,'',NULL,NULL,NULL,-3.3965,'0.03');
INSERT INTO "finding" VALUES(1,'model',4,'vote',0.0101,'',NULL,NULL,NULL,-4.499,'0.01');
INSERT INTO "finding" VALUES(1,'commands',1,'share',1.2842,'',NULL,NULL,1.0,2.6047,'1.284 +28%');
INSERT INTO "finding" VALUES(1,'commands',1,'thrust',0.7,'of normal',0.57,0.88,1.0,NULL,'70 (57-88)');
INSERT INTO "finding" VALUES(1,'commands',2,'share',0.8986,'',NULL,NULL,1.0,-2.0728,'0.899 -10%');
INSERT INTO "finding" VALUES(1,'commands',2,'thrust',1.0,'of normal',0.84,1.0,1.0,NULL,'100 (84-100)');
INSERT INTO "finding" VALUES(1,'commands',3,'share',0.9059,'',NULL,NULL,1.0,-1.8573,'0.906 -9%');
INSERT INTO "finding" VALUES(1,'commands',3,'thrust',1.0,'of normal',0.8,1.0,1.0,NULL,'100 (80-100)');
INSERT INTO "finding" VALUES(1,'commands',4,'share',0.9113,'',NULL,NULL,1.0,-1.8249,'0.911 -9%');
INSERT INTO "finding" VALUES(1,'commands',4,'thrust',1.0,'of normal',0.8,1.0,1.0,NULL,'100 (80-100)');
INSERT INTO "finding" VALUES(1,'effectiveness',1,'effectiveness',0.7861,'of neighbours',0.7393,0.8447,1.0,2.0498,'0.79 .74-.84');
INSERT INTO "finding" VALUES(1,'effectiveness',2,'effectiveness',1.0559,'of neighbours',0.9858,1.1312,1.0,-2.1522,'1.06 .99-1.13');
INSERT INTO "finding" VALUES(1,'effectiveness',3,'effectiveness',0.9993,'of neighbours',0.9784,1.045,1.0,-1.8009,'1.00 .98-1.04');
INSERT INTO "finding" VALUES(1,'effectiveness',4,'effectiveness',0.9999,'of neighbours',0.9762,1.0338,1.0,-1.8148,'1.00 .98-1.03');
INSERT INTO "finding" VALUES(2,'model',1,'vote',0.0649,'',NULL,NULL,NULL,-4.5866,'0.06');
INSERT INTO "finding" VALUES(2,'model',2,'vote',0.2091,'',NULL,NULL,NULL,-2.1311,'0.21');
INSERT INTO "finding" VALUES(2,'model',3,'vote',0.1327,'',NULL,NULL,NULL,-3.3055,'0.13');
INSERT INTO "finding" VALUES(2,'model',4,'vote',0.1375,'',NULL,NULL,NULL,-3.2269,'0.14');
INSERT INTO "finding" VALUES(2,'commands',1,'share',0.9975,'',NULL,NULL,1.0,-1.4038,'0.998 -0%');
INSERT INTO "finding" VALUES(2,'commands',1,'thrust',1.0,'of normal',0.77,1.0,1.0,NULL,'100 (77-100)');
INSERT INTO "finding" VALUES(2,'commands',2,'share',0.998,'',NULL,NULL,1.0,-1.4001,'0.998 -0%');
INSERT INTO "finding" VALUES(2,'commands',2,'thrust',1.0,'of normal',0.77,1.0,1.0,NULL,'100 (77-100)');
INSERT INTO "finding" VALUES(2,'commands',3,'share',1.0024,'',NULL,NULL,1.0,-1.3737,'1.002 +0%');
INSERT INTO "finding" VALUES(2,'commands',3,'thrust',1.0,'of normal',0.77,1.0,1.0,NULL,'100 (77-100)');
INSERT INTO "finding" VALUES(2,'commands',4,'share',1.0021,'',NULL,NULL,1.0,-1.3763,'1.002 +0%');
INSERT INTO "finding" VALUES(2,'commands',4,'thrust',1.0,'of normal',0.77,1.0,1.0,NULL,'100 (77-100)');
INSERT INTO "finding" VALUES(2,'effectiveness',1,'effectiveness',0.9916,'of neighbours',0.9551,1.026,1.0,-1.7164,'0.99 .96-1.03');
INSERT INTO "finding" VALUES(2,'effectiveness',2,'effectiveness',1.0094,'of neighbours',0.979,1.0437,1.0,-1.9031,'1.01 .98-1.04');
INSERT INTO "finding" VALUES(2,'effectiveness',3,'effectiveness',1.0101,'of neighbours',0.9763,1.0511,1.0,-1.8991,'1.01 .98-1.05');
INSERT INTO "finding" VALUES(2,'effectiveness',4,'effectiveness',0.9842,'of neighbours',0.9518,1.02,1.0,-1.6397,'0.98 .95-1.02');
CREATE TABLE flight (
    id               INTEGER PRIMARY KEY,
    sha256           TEXT NOT NULL UNIQUE,  -- content hash: the stored file is DATA/logs/<sha[:2]>/<sha>
    name             TEXT NOT NULL,         -- file name the client sent: shown (escaped), never used as a path
    size_bytes       BIGINT NOT NULL,
    format           TEXT NOT NULL,         -- ulog | dataflash (sniffed from the bytes)
    uploaded_at      TEXT NOT NULL,
    state            TEXT NOT NULL,         -- queued | running | done | error
    airframe         TEXT,                  -- airframe.key as read from the log (merges are applied on reading)
    healthy_mark     INTEGER NOT NULL DEFAULT 0,  -- the operator says this flight had healthy propellers
    autopilot        TEXT,
    firmware         TEXT,
    flight_start_utc TEXT,                  -- ISO-8601 UTC when the log has GPS time
    log_t_start_s    REAL,
    airborne_s       REAL,
    status           TEXT,                  -- healthy | damaged | uncertain | not_diagnosable
    motor            INTEGER,
    confidence       REAL,
    reason           TEXT,
    sentence         TEXT,                  -- the verdict sentence of the terminal report
    profile_sha256   TEXT,                  -- profile used ('' none)
    diagnosis_json   TEXT,                  -- `fdlog diagnose --json` object of this flight
    plot_json        TEXT,                  -- decimated rates / motor commands for the flight page
    error            TEXT,                  -- why it is an error row
    diagnosed_at     TEXT
);
INSERT INTO "flight" VALUES(1,'78c6bfb16c2c8df0f30a26bfa3d7248314f8d381fefa249f58865ab5db4d404e','px4_motor1_damaged.ulg',1234,'ulog','2026-11-25T21:01:52.059Z','done','sim-12-0',0,'px4','flightlog-fd sim',NULL,25.545947,43.679,'damaged',1,0.9999,'motor 1 (front-right) lost thrust: it gives about 70 % of its normal thrust [57-88 %]; it runs +38 % command share against its neighbours; evidence for it (log-likelihood ratio, nats): model +5.0, commands +2.6, effectiveness +2.0; inspect propeller 1','Propeller 1 (front-right) damaged, confidence 1.00, first seen at t=28.4 s','','{"schema": 3, "tool": {"name": "flightlog-fd", "version": "0.1.0"}, "log": "px4_motor1_damaged.ulg", "autopilot": "px4", "firmware": "flightlog-fd sim", "vehicle_type": "quadrotor", "frame": "quad_x", "duration_s": 48.204, "airborne_s": 43.679, "model": {"path": "/work/main/models/default.onnx", "version": "default-2", "sha256": "b16cc2d4efd214e01e43f811799de41618da430e114f443bbb4a08626ea090f1", "calibrated": false}, "profile": null, "verdict": {"status": "damaged", "motor": 1, "position": "front-right", "confidence": 0.9999, "first_seen": 28.38, "reason": "motor 1 (front-right) lost thrust: it gives about 70 % of its normal thrust [57-88 %]; it runs +38 % command share against its neighbours; evidence for it (log-likelihood ratio, nats): model +5.0, commands +2.6, effectiveness +2.0; inspect propeller 1"}, "evidence": {"n_windows": 51, "covered_s": 41.58, "share": [0.0, 1.0, 0.0, 0.0, 0.0], "abstained": 0.0}, "motors": [{"motor": 1, "position": "front-right", "command_share": 1.2842, "command_share_baseline": null, "command_change": 0.3789, "effectiveness": 0.7861, "effectiveness_ci": [0.7393, 0.8447], "model_vote": 0.6305, "llr": 9.6545, "llr_by_source": {"model": 5.0, "commands": 2.6047, "effectiveness": 2.0498}, "eta_hat": 0.7, "eta_ci": [0.57, 0.88], "weight": 0.9999}, {"motor": 2, "position": "rear-left", "command_share": 0.8986, "command_share_baseline": null, "command_change": -0.1352, "effectiveness": 1.0559, "effectiveness_ci": [0.9858, 1.1312], "model_vote": 0.1672, "llr": -3.4978, "llr_by_source": {"model": 0.7271, "commands": -2.0728, "effectiveness": -2.1522}, "eta_hat": 1.0, "eta_ci": [0.84, 1.0], "weight": 0.0}, {"motor": 3, "position": "front-left", "command_share": 0.9059, "command_share_baseline": null, "command_change": -0.1254, "effectiveness": 0.9993, "effectiveness_ci": [0.9784, 1.045], "model_vote": 0.032, "llr": -7.0547, "llr_by_source": {"model": -3.3965, "commands": -1.8573, "effectiveness": -1.8009}, "eta_hat": 1.0, "eta_ci": [0.8, 1.0], "weight": 0.0}, {"motor": 4, "position": "rear-right", "command_share": 0.9113, "command_share_baseline": null, "command_change": -0.1183, "effectiveness": 0.9999, "effectiveness_ci": [0.9762, 1.0338], "model_vote": 0.0101, "llr": -8.1387, "llr_by_source": {"model": -4.499, "commands": -1.8249, "effectiveness": -1.8148}, "eta_hat": 1.0, "eta_ci": [0.8, 1.0], "weight": 0.0}], "motor_evidence": {"baseline": "neighbours", "throttle": 0.5293, "top_motor": 1, "single_motor_gap": 0.4973, "effectiveness": {"informative": true, "reason": "from 38 s of airborne data", "seconds": 37.7, "motor_lag_s": 0.046, "r2": [0.854, 0.83, 0.671]}, "airframe_changed": null, "notes": [], "decision": {"sources": ["model", "commands", "effectiveness"], "healthy_chi2": 7.485, "share_sigma": 0.12}}, "windows": [{"t_start": 28.38, "t_end": 29.96, "class": 1, "probabilities": [0.1695, 0.5857, 0.1962, 0.0387, 0.0098], "phase": "manoeuvre", "smoothed_class": 1}, {"t_start": 29.18, "t_end": 30.76, "class": 1, "probabilities": [0.193, 0.538, 0.1965, 0.056, 0.0165], "phase": "climb", "smoothed_class": 1}, {"t_start": 29.98, "t_end": 31.56, "class": 1, "probabilities": [0.2294, 0.5031, 0.1736, 0.0592, 0.0346], "phase": "climb", "smoothed_class": 1}], "analyzers": [{"analyzer": "model", "abstained": null, "notes": [], "findings": [{"analyzer": "model", "motor": 1, "name": "vote", "value": 0.6305, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": 6.3916, "text": "0.63"}, {"analyzer": "model", "motor": 2, "name": "vote", "value": 0.1672, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": 0.7271, "text": "0.17"}, {"analyzer": "model", "motor": 3, "name": "vote", "value": 0.032, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": -3.3965, "text": "0.03"}, {"analyzer": "model", "motor": 4, "name": "vote", "value": 0.0101, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": -4.499, "text": "0.01"}]}, {"analyzer": "commands", "abstained": null, "notes": [], "findings": [{"analyzer": "commands", "motor": 1, "name": "share", "value": 1.2842, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": 2.6047, "text": "1.284 +28%"}, {"analyzer": "commands", "motor": 1, "name": "thrust", "value": 0.7, "unit": "of normal", "interval": [0.57, 0.88], "baseline": 1.0, "direction": "down", "llr": null, "text": "70 (57-88)"}, {"analyzer": "commands", "motor": 2, "name": "share", "value": 0.8986, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -2.0728, "text": "0.899 -10%"}, {"analyzer": "commands", "motor": 2, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.84, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (84-100)"}, {"analyzer": "commands", "motor": 3, "name": "share", "value": 0.9059, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -1.8573, "text": "0.906 -9%"}, {"analyzer": "commands", "motor": 3, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.8, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (80-100)"}, {"analyzer": "commands", "motor": 4, "name": "share", "value": 0.9113, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -1.8249, "text": "0.911 -9%"}, {"analyzer": "commands", "motor": 4, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.8, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (80-100)"}]}, {"analyzer": "throttle", "abstained": "no calibration profile: the healthy throttle is unknown", "notes": [], "findings": []}, {"analyzer": "effectiveness", "abstained": null, "notes": [], "findings": [{"analyzer": "effectiveness", "motor": 1, "name": "effectiveness", "value": 0.7861, "unit": "of neighbours", "interval": [0.7393, 0.8447], "baseline": 1.0, "direction": "down", "llr": 2.0498, "text": "0.79 .74-.84"}, {"analyzer": "effectiveness", "motor": 2, "name": "effectiveness", "value": 1.0559, "unit": "of neighbours", "interval": [0.9858, 1.1312], "baseline": 1.0, "direction": "down", "llr": -2.1522, "text": "1.06 .99-1.13"}, {"analyzer": "effectiveness", "motor": 3, "name": "effectiveness", "value": 0.9993, "unit": "of neighbours", "interval": [0.9784, 1.045], "baseline": 1.0, "direction": "down", "llr": -1.8009, "text": "1.00 .98-1.04"}, {"analyzer": "effectiveness", "motor": 4, "name": "effectiveness", "value": 0.9999, "unit": "of neighbours", "interval": [0.9762, 1.0338], "baseline": 1.0, "direction": "down", "llr": -1.8148, "text": "1.00 .98-1.03"}]}, {"analyzer": "esc", "abstained": "no ESC telemetry in this log", "notes": [], "findings": []}], "stopped_motors": [], "warnings": ["no calibration profile: using the shipped model; a profile made with `fdlog calibrate` on a healthy flight of this airframe is more accurate"], "exit_code": 1}','null',NULL,'2026-11-25T21:01:58.032Z');
INSERT INTO "flight" VALUES(2,'4e700cdc05a7d98cf233b8033df72d48431e85937cbb52f5459a03d534e7e802','ardupilot_healthy.bin',1234,'dataflash','2026-11-25T21:01:58.057Z','done','log:4e700cdc05a7',0,'ardupilot','ArduCopter V4.5.7 (flightlog-fd)',NULL,244.564754,47.2,'healthy',NULL,0.9919,'no rotor lost thrust: the strongest case is motor 2 (rear-left) at -5.4 nats (damage needs 6)','No propeller damage found, confidence 0.99 (55 windows, 45 s of flight)','','{"schema": 3, "tool": {"name": "flightlog-fd", "version": "0.1.0"}, "log": "ardupilot_healthy.bin", "autopilot": "ardupilot", "firmware": "ArduCopter V4.5.7 (flightlog-fd)", "vehicle_type": "quadrotor", "frame": "quad_x", "duration_s": 53.043, "airborne_s": 47.2, "model": {"path": "/work/main/models/default.onnx", "version": "default-2", "sha256": "b16cc2d4efd214e01e43f811799de41618da430e114f443bbb4a08626ea090f1", "calibrated": false}, "profile": null, "verdict": {"status": "healthy", "motor": null, "position": null, "confidence": 0.9919, "first_seen": null, "reason": "no rotor lost thrust: the strongest case is motor 2 (rear-left) at -5.4 nats (damage needs 6)"}, "evidence": {"n_windows": 55, "covered_s": 44.78, "share": [0.1273, 0.0, 0.0, 0.0, 0.0], "abstained": 0.8727}, "motors": [{"motor": 1, "position": "front-right", "command_share": 0.9975, "command_share_baseline": null, "command_change": -0.0033, "effectiveness": 0.9916, "effectiveness_ci": [0.9551, 1.026], "model_vote": 0.0649, "llr": -7.7068, "llr_by_source": {"model": -4.5866, "commands": -1.4038, "effectiveness": -1.7164}, "eta_hat": 1.0, "eta_ci": [0.77, 1.0], "weight": 0.0004}, {"motor": 2, "position": "rear-left", "command_share": 0.998, "command_share_baseline": null, "command_change": -0.0027, "effectiveness": 1.0094, "effectiveness_ci": [0.979, 1.0437], "model_vote": 0.2091, "llr": -5.4343, "llr_by_source": {"model": -2.1311, "commands": -1.4001, "effectiveness": -1.9031}, "eta_hat": 1.0, "eta_ci": [0.77, 1.0], "weight": 0.0043}, {"motor": 3, "position": "front-left", "command_share": 1.0024, "command_share_baseline": null, "command_change": 0.0032, "effectiveness": 1.0101, "effectiveness_ci": [0.9763, 1.0511], "model_vote": 0.1327, "llr": -6.5783, "llr_by_source": {"model": -3.3055, "commands": -1.3737, "effectiveness": -1.8991}, "eta_hat": 1.0, "eta_ci": [0.77, 1.0], "weight": 0.0014}, {"motor": 4, "position": "rear-right", "command_share": 1.0021, "command_share_baseline": null, "command_change": 0.0028, "effectiveness": 0.9842, "effectiveness_ci": [0.9518, 1.02], "model_vote": 0.1375, "llr": -6.243, "llr_by_source": {"model": -3.2269, "commands": -1.3763, "effectiveness": -1.6397}, "eta_hat": 1.0, "eta_ci": [0.77, 1.0], "weight": 0.0019}], "motor_evidence": {"baseline": "neighbours", "throttle": 0.4658, "top_motor": 3, "single_motor_gap": 0.0005, "effectiveness": {"informative": true, "reason": "from 41 s of airborne data", "seconds": 41.2, "motor_lag_s": 0.082, "r2": [0.843, 0.831, 0.571]}, "airframe_changed": null, "notes": [], "decision": {"sources": ["model", "commands", "effectiveness"], "healthy_chi2": 0.001, "share_sigma": 0.12}}, "windows": [{"t_start": 247.74, "t_end": 249.32, "class": 0, "probabilities": [0.4184, 0.0901, 0.2045, 0.1485, 0.1385], "phase": "climb", "smoothed_class": -1}, {"t_start": 248.54, "t_end": 250.12, "class": 0, "probabilities": [0.4436, 0.1379, 0.1823, 0.1282, 0.1081], "phase": "climb", "smoothed_class": -1}, {"t_start": 249.34, "t_end": 250.92, "class": 0, "probabilities": [0.4086, 0.0978, 0.1968, 0.1459, 0.1509], "phase": "climb", "smoothed_class": -1}], "analyzers": [{"analyzer": "model", "abstained": null, "notes": [], "findings": [{"analyzer": "model", "motor": 1, "name": "vote", "value": 0.0649, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": -4.5866, "text": "0.06"}, {"analyzer": "model", "motor": 2, "name": "vote", "value": 0.2091, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": -2.1311, "text": "0.21"}, {"analyzer": "model", "motor": 3, "name": "vote", "value": 0.1327, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": -3.3055, "text": "0.13"}, {"analyzer": "model", "motor": 4, "name": "vote", "value": 0.1375, "unit": "", "interval": null, "baseline": null, "direction": "up", "llr": -3.2269, "text": "0.14"}]}, {"analyzer": "commands", "abstained": null, "notes": [], "findings": [{"analyzer": "commands", "motor": 1, "name": "share", "value": 0.9975, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -1.4038, "text": "0.998 -0%"}, {"analyzer": "commands", "motor": 1, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.77, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (77-100)"}, {"analyzer": "commands", "motor": 2, "name": "share", "value": 0.998, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -1.4001, "text": "0.998 -0%"}, {"analyzer": "commands", "motor": 2, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.77, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (77-100)"}, {"analyzer": "commands", "motor": 3, "name": "share", "value": 1.0024, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -1.3737, "text": "1.002 +0%"}, {"analyzer": "commands", "motor": 3, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.77, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (77-100)"}, {"analyzer": "commands", "motor": 4, "name": "share", "value": 1.0021, "unit": "", "interval": null, "baseline": 1.0, "direction": "up", "llr": -1.3763, "text": "1.002 +0%"}, {"analyzer": "commands", "motor": 4, "name": "thrust", "value": 1.0, "unit": "of normal", "interval": [0.77, 1.0], "baseline": 1.0, "direction": "down", "llr": null, "text": "100 (77-100)"}]}, {"analyzer": "throttle", "abstained": "no calibration profile: the healthy throttle is unknown", "notes": [], "findings": []}, {"analyzer": "effectiveness", "abstained": null, "notes": [], "findings": [{"analyzer": "effectiveness", "motor": 1, "name": "effectiveness", "value": 0.9916, "unit": "of neighbours", "interval": [0.9551, 1.026], "baseline": 1.0, "direction": "down", "llr": -1.7164, "text": "0.99 .96-1.03"}, {"analyzer": "effectiveness", "motor": 2, "name": "effectiveness", "value": 1.0094, "unit": "of neighbours", "interval": [0.979, 1.0437], "baseline": 1.0, "direction": "down", "llr": -1.9031, "text": "1.01 .98-1.04"}, {"analyzer": "effectiveness", "motor": 3, "name": "effectiveness", "value": 1.0101, "unit": "of neighbours", "interval": [0.9763, 1.0511], "baseline": 1.0, "direction": "down", "llr": -1.8991, "text": "1.01 .98-1.05"}, {"analyzer": "effectiveness", "motor": 4, "name": "effectiveness", "value": 0.9842, "unit": "of neighbours", "interval": [0.9518, 1.02], "baseline": 1.0, "direction": "down", "llr": -1.6397, "text": "0.98 .95-1.02"}]}, {"analyzer": "esc", "abstained": "no ESC telemetry in this log", "notes": [], "findings": []}], "stopped_motors": [], "warnings": ["no calibration profile: using the shipped model; a profile made with `fdlog calibrate` on a healthy flight of this airframe is more accurate"], "exit_code": 0}','null',NULL,'2026-11-25T21:02:00.756Z');
CREATE TABLE job (
    id          INTEGER PRIMARY KEY,
    kind        TEXT NOT NULL,      -- diagnose | calibrate
    flight_id   BIGINT REFERENCES flight(id),
    airframe    TEXT,               -- calibrate: the airframe
    args        TEXT NOT NULL,      -- JSON: calibrate's flight ids and mode
    state       TEXT NOT NULL,      -- queued | running | done | error
    attempts    INTEGER NOT NULL DEFAULT 0,   -- claims so far
    worker      TEXT,               -- the server that holds it
    lease_until REAL,             -- POSIX s: past it the holder is taken for dead
    error       TEXT,
    created_at  TEXT NOT NULL,
    started_at  TEXT,
    finished_at TEXT
);
INSERT INTO "job" VALUES(1,'diagnose',1,NULL,'{}','done',1,'gen',NULL,NULL,'2026-11-25T21:01:52.059Z','2026-11-25T21:01:52.079Z','2026-11-25T21:01:58.031Z');
INSERT INTO "job" VALUES(2,'diagnose',2,NULL,'{}','done',1,'gen',NULL,NULL,'2026-11-25T21:01:58.057Z','2026-11-25T21:01:58.058Z','2026-11-25T21:02:00.756Z');
CREATE TABLE motor_figure (
    flight_id              BIGINT NOT NULL REFERENCES flight(id) ON DELETE CASCADE,
    motor                  INTEGER NOT NULL,
    position               TEXT,
    command_share          REAL,   -- mean thrust command / mean of the four (1 = even)
    command_share_baseline REAL,
    command_change         REAL,   -- share - baseline (or - the other three)
    effectiveness          REAL,
    effectiveness_ci_lo    REAL,
    effectiveness_ci_hi    REAL,
    model_vote             REAL,   -- mean model probability that this propeller is damaged
    severity               REAL,   -- estimated remaining thrust (eta-hat) when the report has it
    PRIMARY KEY (flight_id, motor)
);
INSERT INTO "motor_figure" VALUES(1,1,'front-right',1.2842,NULL,0.3789,0.7861,0.7393,0.8447,0.6305,0.7);
INSERT INTO "motor_figure" VALUES(1,2,'rear-left',0.8986,NULL,-0.1352,1.0559,0.9858,1.1312,0.1672,1.0);
INSERT INTO "motor_figure" VALUES(1,3,'front-left',0.9059,NULL,-0.1254,0.9993,0.9784,1.045,0.032,1.0);
INSERT INTO "motor_figure" VALUES(1,4,'rear-right',0.9113,NULL,-0.1183,0.9999,0.9762,1.0338,0.0101,1.0);
INSERT INTO "motor_figure" VALUES(2,1,'front-right',0.9975,NULL,-0.0033,0.9916,0.9551,1.026,0.0649,1.0);
INSERT INTO "motor_figure" VALUES(2,2,'rear-left',0.998,NULL,-0.0027,1.0094,0.979,1.0437,0.2091,1.0);
INSERT INTO "motor_figure" VALUES(2,3,'front-left',1.0024,NULL,0.0032,1.0101,0.9763,1.0511,0.1327,1.0);
INSERT INTO "motor_figure" VALUES(2,4,'rear-right',1.0021,NULL,0.0028,0.9842,0.9518,1.02,0.1375,1.0);
CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, name TEXT NOT NULL, applied_at TEXT NOT NULL);
INSERT INTO "schema_migrations" VALUES(1,'flights, motor figures, jobs, airframes','2026-11-25T21:01:52.012Z');
INSERT INTO "schema_migrations" VALUES(2,'findings of every analyzer','2026-11-25T21:01:52.012Z');
CREATE INDEX flight_airframe ON flight (airframe, flight_start_utc);
CREATE INDEX job_state ON job (state, id);
CREATE INDEX job_flight ON job (flight_id)
;
CREATE INDEX finding_flight ON finding (flight_id)
;
COMMIT;
