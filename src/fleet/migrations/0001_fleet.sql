-- wheelflat fleet store, version 1: every site's passes, refusals and alarms, the sites'
-- heartbeats, the workshop's findings (docs/fleet.md). Run by `wheelflat fleet migrate` as
-- the database's owner, in one transaction.

CREATE SCHEMA fleet;

-- The migrations applied, one row each (`wheelflat fleet migrate`).
CREATE TABLE fleet.schema_migrations (
    version integer PRIMARY KEY,
    name text NOT NULL,
    wheelflat text NOT NULL,
    applied_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp())
);

-- The three kinds of login the store knows, as group roles (cluster-wide: made once).
DO $$
BEGIN
  IF NOT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = 'wheelflat_site') THEN
    CREATE ROLE wheelflat_site NOLOGIN;
  END IF;
  IF NOT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = 'wheelflat_reader') THEN
    CREATE ROLE wheelflat_reader NOLOGIN;
  END IF;
  IF NOT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = 'wheelflat_workshop') THEN
    CREATE ROLE wheelflat_workshop NOLOGIN;
  END IF;
END
$$;

-- A site and the login role it ships with (one role a site).
CREATE TABLE fleet.sites (
    site text PRIMARY KEY CHECK (site ~ '^[a-z0-9][a-z0-9_-]{0,39}$'),
    role_name name NOT NULL UNIQUE,
    created_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp())
);

-- The site a login ships as (none for a login that is not a site's).
CREATE FUNCTION fleet.my_site() RETURNS text
    LANGUAGE sql STABLE
    AS $$ SELECT site FROM fleet.sites WHERE role_name = current_user $$;

-- A pass as its site stored it: `seq` is the site's own row id (the order it was stored in),
-- `key` what makes the pass itself.
CREATE TABLE fleet.passes (
    site text NOT NULL REFERENCES fleet.sites(site),
    seq bigint NOT NULL CHECK (seq > 0),
    key text NOT NULL,
    time text NOT NULL,
    time_s double precision NOT NULL,
    measurement text NOT NULL,
    bank_id text NOT NULL,
    speed_km_per_h double precision,
    bank_speed_km_per_h double precision NOT NULL,
    load_kn double precision,
    bogie_id text,
    summary text NOT NULL,
    result_dir text,
    answer_ms double precision,
    received_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp()),
    PRIMARY KEY (site, seq),
    UNIQUE (site, key)
);
CREATE INDEX passes_by_time ON fleet.passes (time_s);
CREATE INDEX passes_by_bank ON fleet.passes (site, bank_id, time_s);

CREATE TABLE fleet.wheel_passes (
    site text NOT NULL,
    seq bigint NOT NULL,
    wheel text NOT NULL CHECK (wheel IN ('leading', 'trailing')),
    wheel_id text,
    time_s double precision NOT NULL,
    claim text NOT NULL,
    l0_min_mm double precision,
    l0_max_mm double precision,
    severity_lowest text,
    severity_highest text,
    limit_l0_mm double precision,
    space text NOT NULL,
    cells integer NOT NULL,
    boxes bytea NOT NULL,
    dynamic_ratio_min double precision,
    dynamic_ratio_max double precision,
    PRIMARY KEY (site, seq, wheel),
    FOREIGN KEY (site, seq) REFERENCES fleet.passes (site, seq)
);
CREATE INDEX wheel_passes_by_wheel ON fleet.wheel_passes (wheel_id, time_s);

-- Each named wheel's newest pass at any site (kept by a trigger as wheels are inserted): the
-- fleet page's "needing action" list without scanning every pass.
CREATE TABLE fleet.wheels (
    wheel_id text PRIMARY KEY,
    site text NOT NULL,
    seq bigint NOT NULL,
    time_s double precision NOT NULL,
    claim text NOT NULL,
    severity_lowest text,
    severity_highest text,
    l0_min_mm double precision,
    l0_max_mm double precision,
    passes bigint NOT NULL
);
CREATE INDEX wheels_by_class ON fleet.wheels (severity_highest, time_s);

CREATE FUNCTION fleet.keep_wheel() RETURNS trigger
    LANGUAGE plpgsql SECURITY DEFINER SET search_path = fleet, pg_temp
    AS $$
BEGIN
  IF NEW.wheel_id IS NOT NULL THEN
    INSERT INTO fleet.wheels AS w (wheel_id, site, seq, time_s, claim, severity_lowest,
                                   severity_highest, l0_min_mm, l0_max_mm, passes)
    VALUES (NEW.wheel_id, NEW.site, NEW.seq, NEW.time_s, NEW.claim, NEW.severity_lowest,
            NEW.severity_highest, NEW.l0_min_mm, NEW.l0_max_mm, 1)
    ON CONFLICT (wheel_id) DO UPDATE SET
      site = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.site ELSE w.site END,
      seq = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.seq ELSE w.seq END,
      claim = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.claim ELSE w.claim END,
      severity_lowest = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.severity_lowest ELSE w.severity_lowest END,
      severity_highest = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.severity_highest ELSE w.severity_highest END,
      l0_min_mm = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.l0_min_mm ELSE w.l0_min_mm END,
      l0_max_mm = CASE WHEN EXCLUDED.time_s >= w.time_s THEN EXCLUDED.l0_max_mm ELSE w.l0_max_mm END,
      time_s = greatest(EXCLUDED.time_s, w.time_s),
      passes = w.passes + 1;
  END IF;
  RETURN NULL;
END
$$;
CREATE TRIGGER keep_wheel AFTER INSERT ON fleet.wheel_passes
    FOR EACH ROW EXECUTE FUNCTION fleet.keep_wheel();

CREATE TABLE fleet.failures (
    site text NOT NULL REFERENCES fleet.sites(site),
    seq bigint NOT NULL CHECK (seq > 0),
    time text NOT NULL,
    time_s double precision NOT NULL,
    measurement text NOT NULL,
    bogie_id text,
    outcome text NOT NULL CHECK (outcome IN ('refused', 'failed')),
    reason text NOT NULL,
    received_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp()),
    PRIMARY KEY (site, seq)
);
CREATE INDEX failures_by_time ON fleet.failures (site, time_s);

-- What each site raised (its delivery stays the site's).
CREATE TABLE fleet.alarms (
    site text NOT NULL REFERENCES fleet.sites(site),
    seq bigint NOT NULL CHECK (seq > 0),
    destination text NOT NULL,
    key text NOT NULL,
    rule text NOT NULL,
    wheel_id text,
    pass_seq bigint,
    created text NOT NULL,
    created_s double precision NOT NULL,
    body text NOT NULL,
    received_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp()),
    PRIMARY KEY (site, seq)
);
CREATE INDEX alarms_by_rule ON fleet.alarms (site, rule, created_s);

-- One row a shipping round: what the site had and what was still to ship after it.
CREATE TABLE fleet.heartbeats (
    site text NOT NULL REFERENCES fleet.sites(site),
    at_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp()),
    pending integer NOT NULL CHECK (pending >= 0),
    newest_pass_s double precision,
    oldest_pending_s double precision,
    wheelflat text NOT NULL,
    PRIMARY KEY (site, at_s)
);

-- What the workshop measured on a pulled wheelset: once a wheel and day.
CREATE TABLE fleet.findings (
    id bigserial PRIMARY KEY,
    wheel_id text NOT NULL,
    found_on date NOT NULL,
    length_mm double precision NOT NULL CHECK (length_mm >= 0 AND length_mm <= 500),
    depth_mm double precision NOT NULL CHECK (depth_mm >= 0 AND depth_mm <= 20),
    note text NOT NULL DEFAULT '',
    entered_by name NOT NULL DEFAULT current_user,
    entered_s double precision NOT NULL DEFAULT extract(epoch FROM clock_timestamp()),
    UNIQUE (wheel_id, found_on)
);

-- Who may do what: a site inserts (never updates or deletes) its own rows and reads them
-- back; a reader reads everything; the workshop inserts findings.
GRANT USAGE ON SCHEMA fleet TO wheelflat_site, wheelflat_reader, wheelflat_workshop;
GRANT SELECT ON fleet.sites TO wheelflat_site, wheelflat_reader, wheelflat_workshop;
GRANT SELECT ON fleet.schema_migrations TO wheelflat_site, wheelflat_reader, wheelflat_workshop;
GRANT INSERT, SELECT ON fleet.passes, fleet.wheel_passes, fleet.failures, fleet.alarms, fleet.heartbeats TO wheelflat_site;
GRANT SELECT ON ALL TABLES IN SCHEMA fleet TO wheelflat_reader;
GRANT INSERT, SELECT ON fleet.findings TO wheelflat_workshop;
GRANT USAGE ON SEQUENCE fleet.findings_id_seq TO wheelflat_workshop;
GRANT SELECT ON fleet.wheel_passes, fleet.passes TO wheelflat_workshop;

ALTER TABLE fleet.passes ENABLE ROW LEVEL SECURITY;
ALTER TABLE fleet.wheel_passes ENABLE ROW LEVEL SECURITY;
ALTER TABLE fleet.failures ENABLE ROW LEVEL SECURITY;
ALTER TABLE fleet.alarms ENABLE ROW LEVEL SECURITY;
ALTER TABLE fleet.heartbeats ENABLE ROW LEVEL SECURITY;

CREATE POLICY own_rows_in ON fleet.passes FOR INSERT TO wheelflat_site WITH CHECK (site = fleet.my_site());
CREATE POLICY own_rows_out ON fleet.passes FOR SELECT TO wheelflat_site USING (site = fleet.my_site());
CREATE POLICY every_row ON fleet.passes FOR SELECT TO wheelflat_reader, wheelflat_workshop USING (true);
CREATE POLICY own_rows_in ON fleet.wheel_passes FOR INSERT TO wheelflat_site WITH CHECK (site = fleet.my_site());
CREATE POLICY own_rows_out ON fleet.wheel_passes FOR SELECT TO wheelflat_site USING (site = fleet.my_site());
CREATE POLICY every_row ON fleet.wheel_passes FOR SELECT TO wheelflat_reader, wheelflat_workshop USING (true);
CREATE POLICY own_rows_in ON fleet.failures FOR INSERT TO wheelflat_site WITH CHECK (site = fleet.my_site());
CREATE POLICY own_rows_out ON fleet.failures FOR SELECT TO wheelflat_site USING (site = fleet.my_site());
CREATE POLICY every_row ON fleet.failures FOR SELECT TO wheelflat_reader USING (true);
CREATE POLICY own_rows_in ON fleet.alarms FOR INSERT TO wheelflat_site WITH CHECK (site = fleet.my_site());
CREATE POLICY own_rows_out ON fleet.alarms FOR SELECT TO wheelflat_site USING (site = fleet.my_site());
CREATE POLICY every_row ON fleet.alarms FOR SELECT TO wheelflat_reader USING (true);
CREATE POLICY own_rows_in ON fleet.heartbeats FOR INSERT TO wheelflat_site WITH CHECK (site = fleet.my_site());
CREATE POLICY own_rows_out ON fleet.heartbeats FOR SELECT TO wheelflat_site USING (site = fleet.my_site());
CREATE POLICY every_row ON fleet.heartbeats FOR SELECT TO wheelflat_reader USING (true);
