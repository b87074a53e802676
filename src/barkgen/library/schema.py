"""The library database's schema, as migrations by version (``PRAGMA user_version``): 1 made
the exemplars, their analyses and results; 2 adds the web app's job queue (``jobs``), so that a
restarted server finds its queued jobs again and says which were interrupted; 3 adds the maps of
an exemplar that is a scanned material set (``exemplar_maps``: file name, map kind, file hash;
the exemplar's photo is the set's colour)."""

#: what the migrations below bring a database to
SCHEMA_VERSION = 3

MIGRATIONS = {
    1: """
    CREATE TABLE exemplars (
        id INTEGER PRIMARY KEY,
        name TEXT NOT NULL,
        species TEXT,
        bark_type TEXT,
        licence TEXT,
        source TEXT,
        image_hash TEXT NOT NULL UNIQUE,
        width INTEGER NOT NULL,
        height INTEGER NOT NULL,
        created TEXT NOT NULL
    );
    CREATE TABLE analyses (
        id INTEGER PRIMARY KEY,
        exemplar_id INTEGER NOT NULL REFERENCES exemplars(id) ON DELETE CASCADE,
        kind TEXT NOT NULL,
        params TEXT NOT NULL,
        file_hash TEXT NOT NULL,
        created TEXT NOT NULL,
        UNIQUE (exemplar_id, kind, params)
    );
    CREATE TABLE results (
        id INTEGER PRIMARY KEY,
        exemplar_id INTEGER NOT NULL REFERENCES exemplars(id) ON DELETE CASCADE,
        params TEXT NOT NULL,
        seed INTEGER NOT NULL,
        timings TEXT NOT NULL,
        parent_id INTEGER REFERENCES results(id) ON DELETE SET NULL,
        created TEXT NOT NULL
    );
    CREATE TABLE result_files (
        result_id INTEGER NOT NULL REFERENCES results(id) ON DELETE CASCADE,
        name TEXT NOT NULL,
        file_hash TEXT NOT NULL,
        PRIMARY KEY (result_id, name)
    );
    CREATE INDEX results_by_exemplar ON results(exemplar_id);
    CREATE TABLE settings (key TEXT PRIMARY KEY, value TEXT NOT NULL);
    """,
    2: """
    CREATE TABLE jobs (
        id TEXT PRIMARY KEY,
        number INTEGER NOT NULL,
        kind TEXT NOT NULL,
        exemplar_id INTEGER NOT NULL,
        params TEXT NOT NULL,
        state TEXT NOT NULL,
        spec TEXT,
        parent_id INTEGER,
        labels_key TEXT,
        result_id INTEGER,
        error TEXT,
        created REAL NOT NULL,
        started REAL,
        finished REAL
    );
    """,
    3: """
    CREATE TABLE exemplar_maps (
        exemplar_id INTEGER NOT NULL REFERENCES exemplars(id) ON DELETE CASCADE,
        name TEXT NOT NULL,
        kind TEXT NOT NULL,
        file_hash TEXT NOT NULL,
        PRIMARY KEY (exemplar_id, name)
    );
    """,
}
