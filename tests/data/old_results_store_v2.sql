-- A results store as fdlog 0.1 (main 81f2534) wrote it: fdlog diagnose sample_logs/px4_motor1_damaged.ulg
-- sample_logs/ardupilot_healthy.bin --db results.sqlite, dumped with sqlite3's iterdump (schema 2).
PRAGMA user_version = 2;
BEGIN TRANSACTION;
CREATE TABLE diagnosis (
    id               INTEGER PRIMARY KEY,
    log_path         TEXT NOT NULL,    -- as given on the command line
    log_sha256       TEXT NOT NULL,
    vehicle          TEXT NOT NULL,    -- airframe identity (module docstring)
    vehicle_source   TEXT NOT NULL,    -- sys_uuid, ver_hw, board_uid, BRD_SERIAL_NUM, SYSID_THISMAV, profile, unknown
    autopilot        TEXT,
    flight_start_utc TEXT,             -- ISO-8601 UTC ("2024-05-01T09:30:00Z") when the log has GPS time, else NULL
    log_t_start_s    REAL,             -- start of the log on its own clock (s since boot)
    airborne_s       REAL,
    status           TEXT NOT NULL,    -- healthy | damaged | stopped | uncertain | not_diagnosable
    motor            INTEGER,          -- 1..4 for damaged
    confidence       REAL,
    reason           TEXT,
    exit_code        INTEGER NOT NULL,
    model_version    TEXT,
    model_sha256     TEXT NOT NULL,
    profile_path     TEXT,
    profile_sha256   TEXT NOT NULL,    -- '' without a profile (NULLs would never conflict)
    tool_version     TEXT NOT NULL,
    diagnosed_at     TEXT NOT NULL,    -- ISO-8601 UTC
    UNIQUE (log_sha256, model_sha256, profile_sha256)
);
INSERT INTO "diagnosis" VALUES(1,'/work/main/sample_logs/px4_motor1_damaged.ulg','78c6bfb16c2c8df0f30a26bfa3d7248314f8d381fefa249f58865ab5db4d404e','sim-12-0','sys_uuid','px4',NULL,25.545947,4.36793240000000082545e+01,'damaged',1,9.99933852162179448441e-01,'motor 1 (front-right) lost thrust: it gives about 70 % of its normal thrust [57-88 %]; it runs +38 % command share against its neighbours; evidence for it (log-likelihood ratio, nats): model +5.0, commands +2.6, effectiveness +2.0; inspect propeller 1',1,'default-2','b16cc2d4efd214e01e43f811799de41618da430e114f443bbb4a08626ea090f1',NULL,'','0.1.0','2026-11-25T21:01:44Z');
INSERT INTO "diagnosis" VALUES(2,'/work/main/sample_logs/ardupilot_healthy.bin','4e700cdc05a7d98cf233b8033df72d48431e85937cbb52f5459a03d534e7e802','unknown','unknown','ardupilot',NULL,244.564754,4.72004119999999716128e+01,'healthy',NULL,9.91917755845567183925e-01,'no rotor lost thrust: the strongest case is motor 2 (rear-left) at -5.4 nats (damage needs 6)',0,'default-2','b16cc2d4efd214e01e43f811799de41618da430e114f443bbb4a08626ea090f1',NULL,'','0.1.0','2026-11-25T21:01:44Z');
CREATE TABLE finding (      -- every analyzer's per-motor findings (flightlog_fd.analyzers)
    diagnosis_id INTEGER NOT NULL REFERENCES diagnosis(id) ON DELETE CASCADE,
    analyzer     TEXT NOT NULL,             -- the analyzer's id (model, commands, throttle, ...)
    motor        INTEGER NOT NULL,          -- 1..n, the autopilot's numbering
    name         TEXT NOT NULL,             -- the figure (vote, share, thrust, ...)
    value        REAL,
    unit         TEXT NOT NULL,
    lo           REAL,                      -- its interval, when it has one
    hi           REAL,
    baseline     REAL,                      -- the healthy value it is compared with
    direction    TEXT NOT NULL,             -- up | down | '' (which way damage moves it)
    llr          REAL,                      -- its weight in the decision (nats), NULL if not weighed
    PRIMARY KEY (diagnosis_id, analyzer, name, motor)
);
INSERT INTO "finding" VALUES(1,'model',1,'vote',6.3051262381030059867e-01,'',NULL,NULL,NULL,'up',6.39156106121237588268e+00);
INSERT INTO "finding" VALUES(1,'model',2,'vote',1.67245587151424568439e-01,'',NULL,NULL,NULL,'up',7.27118811758961203217e-01);
INSERT INTO "finding" VALUES(1,'model',3,'vote',3.19899823242688896574e-02,'',NULL,NULL,NULL,'up',-3.39652615408576119548e+00);
INSERT INTO "finding" VALUES(1,'model',4,'vote',1.01040365216071154064e-02,'',NULL,NULL,NULL,'up',-4.49896583324841348172e+00);
INSERT INTO "finding" VALUES(1,'commands',1,'share',1.28421079179414565629e+00,'',NULL,NULL,1.0,'up',2.60471623153480802415e+00);
INSERT INTO "finding" VALUES(1,'commands',1,'thrust',0.7,'of normal',0.57,0.88,1.0,'down',NULL);
INSERT INTO "finding" VALUES(1,'commands',2,'share',8.98585482899073362261e-01,'',NULL,NULL,1.0,'up',-2.07277990148722057739e+00);
INSERT INTO "finding" VALUES(1,'commands',2,'thrust',1.0,'of normal',0.84,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(1,'commands',3,'share',9.05948280235324587827e-01,'',NULL,NULL,1.0,'up',-1.85725056490171880341e+00);
INSERT INTO "finding" VALUES(1,'commands',3,'thrust',1.0,'of normal',0.8,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(1,'commands',4,'share',9.11255445071456615657e-01,'',NULL,NULL,1.0,'up',-1.82492492829509878049e+00);
INSERT INTO "finding" VALUES(1,'commands',4,'thrust',1.0,'of normal',0.8,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(1,'effectiveness',1,'effectiveness',7.86146163287883337211e-01,'of neighbours',7.3932852231650769692e-01,8.44740827796724547127e-01,1.0,'down',2.04977136140164351019e+00);
INSERT INTO "finding" VALUES(1,'effectiveness',2,'effectiveness',1.05590616540677317836e+00,'of neighbours',9.85771340046682542634e-01,1.13117847807911964252e+00,1.0,'down',-2.15215099437420942507e+00);
INSERT INTO "finding" VALUES(1,'effectiveness',3,'effectiveness',9.99340555858511891962e-01,'of neighbours',9.7838055211728036653e-01,1.04496221048261,1.0,'down',-1.80094646370435951254e+00);
INSERT INTO "finding" VALUES(1,'effectiveness',4,'effectiveness',9.99914864808053360789e-01,'of neighbours',0.976203335822166,1.03377107289868441775e+00,1.0,'down',-1.81481813981460127216e+00);
INSERT INTO "finding" VALUES(2,'model',1,'vote',6.49281600998206503971e-02,'',NULL,NULL,NULL,'up',-4.58660511999596209875e+00);
INSERT INTO "finding" VALUES(2,'model',2,'vote',2.09062140096317627957e-01,'',NULL,NULL,NULL,'up',-2.13108682954132833131e+00);
INSERT INTO "finding" VALUES(2,'model',3,'vote',1.32654874196106747907e-01,'',NULL,NULL,NULL,'up',-3.30553367205103842962e+00);
INSERT INTO "finding" VALUES(2,'model',4,'vote',1.37537526271559962243e-01,'',NULL,NULL,NULL,'up',-3.22693541728636779097e+00);
INSERT INTO "finding" VALUES(2,'commands',1,'share',0.997518921769752,'',NULL,NULL,1.0,'up',-1.40376118048689835227e+00);
INSERT INTO "finding" VALUES(2,'commands',1,'thrust',1.0,'of normal',0.77,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(2,'commands',2,'share',9.97995648948264646449e-01,'',NULL,NULL,1.0,'up',-1.40014056272685882831e+00);
INSERT INTO "finding" VALUES(2,'commands',2,'thrust',1.0,'of normal',0.77,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(2,'commands',3,'share',1.00241195473226807344e+00,'',NULL,NULL,1.0,'up',-1.37372711931777868876e+00);
INSERT INTO "finding" VALUES(2,'commands',3,'thrust',1.0,'of normal',0.77,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(2,'commands',4,'share',1.00207347454971507083e+00,'',NULL,NULL,1.0,'up',-1.37633180348321326746e+00);
INSERT INTO "finding" VALUES(2,'commands',4,'thrust',1.0,'of normal',0.77,1.0,1.0,'down',NULL);
INSERT INTO "finding" VALUES(2,'effectiveness',1,'effectiveness',9.91571836540472428822e-01,'of neighbours',9.55065611043658058143e-01,1.02599580529079226209e+00,1.0,'down',-1.71639284367627897864e+00);
INSERT INTO "finding" VALUES(2,'effectiveness',2,'effectiveness',1.00943690339102420949e+00,'of neighbours',9.79042613952928353349e-01,1.04372838581732607643e+00,1.0,'down',-1.90311829016366096389e+00);
INSERT INTO "finding" VALUES(2,'effectiveness',3,'effectiveness',1.0101469954003734486e+00,'of neighbours',9.76295421806267271769e-01,1.05106122248733124813e+00,1.0,'down',-1.89906133303453783511e+00);
INSERT INTO "finding" VALUES(2,'effectiveness',4,'effectiveness',9.84228184014406481949e-01,'of neighbours',9.51837448499074589847e-01,1.01999465071477657396e+00,1.0,'down',-1.639713178865321197e+00);
CREATE TABLE motor_figure (
    diagnosis_id           INTEGER NOT NULL REFERENCES diagnosis(id) ON DELETE CASCADE,
    motor                  INTEGER NOT NULL,   -- 1..4
    position               TEXT,
    command_share          REAL,   -- mean thrust command / mean of the four while airborne (1 = even)
    command_share_baseline REAL,   -- the same from the calibration profile
    effectiveness          REAL,   -- 1.0 = as effective as its neighbours
    effectiveness_ci_lo    REAL,
    effectiveness_ci_hi    REAL,
    model_vote             REAL,   -- mean model probability that this motor is damaged
    PRIMARY KEY (diagnosis_id, motor)
);
INSERT INTO "motor_figure" VALUES(1,1,'front-right',1.28421079179414565629e+00,NULL,7.86146163287883337211e-01,7.3932852231650769692e-01,8.44740827796724547127e-01,6.3051262381030059867e-01);
INSERT INTO "motor_figure" VALUES(1,2,'rear-left',8.98585482899073362261e-01,NULL,1.05590616540677317836e+00,9.85771340046682542634e-01,1.13117847807911964252e+00,1.67245587151424568439e-01);
INSERT INTO "motor_figure" VALUES(1,3,'front-left',9.05948280235324587827e-01,NULL,9.99340555858511891962e-01,9.7838055211728036653e-01,1.04496221048261,3.19899823242688896574e-02);
INSERT INTO "motor_figure" VALUES(1,4,'rear-right',9.11255445071456615657e-01,NULL,9.99914864808053360789e-01,0.976203335822166,1.03377107289868441775e+00,1.01040365216071154064e-02);
INSERT INTO "motor_figure" VALUES(2,1,'front-right',0.997518921769752,NULL,9.91571836540472428822e-01,9.55065611043658058143e-01,1.02599580529079226209e+00,6.49281600998206503971e-02);
INSERT INTO "motor_figure" VALUES(2,2,'rear-left',9.97995648948264646449e-01,NULL,1.00943690339102420949e+00,9.79042613952928353349e-01,1.04372838581732607643e+00,2.09062140096317627957e-01);
INSERT INTO "motor_figure" VALUES(2,3,'front-left',1.00241195473226807344e+00,NULL,1.0101469954003734486e+00,9.76295421806267271769e-01,1.05106122248733124813e+00,1.32654874196106747907e-01);
INSERT INTO "motor_figure" VALUES(2,4,'rear-right',1.00207347454971507083e+00,NULL,9.84228184014406481949e-01,9.51837448499074589847e-01,1.01999465071477657396e+00,1.37537526271559962243e-01);
CREATE TABLE schema_version (version INTEGER NOT NULL, tool_version TEXT NOT NULL);
INSERT INTO "schema_version" VALUES(2,'0.1.0');
CREATE INDEX diagnosis_vehicle ON diagnosis (vehicle, flight_start_utc);
CREATE INDEX diagnosis_sha256 ON diagnosis (log_sha256);
CREATE INDEX diagnosis_flight_time ON diagnosis (flight_start_utc);
COMMIT;
