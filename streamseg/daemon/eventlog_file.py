"""The event log's SQLite file: its schema, its reserve of free pages, the writer's
transaction of one batch, and one bounded step of retention (the writer thread runs them)."""

from __future__ import annotations

import sqlite3
import time

from streamseg import protocol

SCHEMA = """
CREATE TABLE IF NOT EXISTS events (
    id INTEGER PRIMARY KEY,
    stream TEXT NOT NULL,
    seq INTEGER NOT NULL,
    type TEXT NOT NULL,
    t REAL NOT NULL,
    body BLOB NOT NULL
);
CREATE INDEX IF NOT EXISTS events_stream_seq ON events (stream, seq);
CREATE TABLE IF NOT EXISTS skips (
    stream TEXT NOT NULL,
    lo INTEGER NOT NULL,
    hi INTEGER NOT NULL,
    t REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS skips_stream ON skips (stream, hi);
CREATE TABLE IF NOT EXISTS open_takes (stream TEXT PRIMARY KEY);
"""

#: free pages the log keeps in its own file (4 kB each: 4 MB, some 20,000 events), so it can
#: still write when the disk is full (the checkpoints pause first)
RESERVE_PAGES = 1024
#: rows deleted by one retention step at most (the next step follows at once): a long delete
#: would hold back the commits, and so the publication, of the events behind it
RETAIN_STEP = 20_000


def reserve(con) -> None:
    """Grow the file's free pages to :data:`RESERVE_PAGES` (a blob written and deleted: its
    pages stay in the file, and the WAL keeps the size it reached); raises
    ``sqlite3.OperationalError`` when there is no room for it (rolled back)."""
    free = con.execute("PRAGMA freelist_count").fetchone()[0]
    if free >= RESERVE_PAGES:
        return
    size = con.execute("PRAGMA page_size").fetchone()[0]
    try:
        con.execute("BEGIN")
        con.execute("CREATE TABLE IF NOT EXISTS reserve (b BLOB)")
        con.execute("INSERT INTO reserve VALUES (zeroblob(?))", ((RESERVE_PAGES - free) * size,))
        con.execute("DROP TABLE reserve")
        con.execute("COMMIT")
    except sqlite3.OperationalError:
        con.execute("ROLLBACK")
        raise


def write_rows(con, batch: list, skips: list = ()) -> None:
    """Commit one batch of event rows and skipped ranges in one transaction, with the takes
    it opens and closes (``open_takes``); raises ``sqlite3.Error`` (the caller rolls back)."""
    con.execute("BEGIN")
    con.executemany("INSERT INTO events (stream, seq, type, t, body) VALUES (?, ?, ?, ?, ?)", batch)
    con.executemany("INSERT INTO skips VALUES (?, ?, ?, ?)", skips)
    opened: dict = {}  # stream -> its take is open after this batch
    for row in batch:
        if row[2] == "closed":
            opened[row[0]] = False
        elif row[2] != "error" and row[0] != protocol.DAEMON_WIDE:
            opened[row[0]] = True
    con.executemany(
        "INSERT OR IGNORE INTO open_takes VALUES (?)",
        [(k,) for k, v in opened.items() if v],
    )
    con.executemany(
        "DELETE FROM open_takes WHERE stream = ?",
        [(k,) for k, v in opened.items() if not v],
    )
    con.execute("COMMIT")


def retain_step(con, max_age: float, max_bytes: int, on_deleted) -> bool:
    """One step of retention: delete events older than ``max_age`` seconds, then the oldest
    while the live pages exceed ``max_bytes``, at most :data:`RETAIN_STEP` rows (each
    delete's row count goes to ``on_deleted``); True when more is due. Raises
    ``sqlite3.Error``."""
    more, deleted = False, 0

    def delete(cut: int) -> int:
        n = con.execute("DELETE FROM events WHERE id <= ?", (cut,)).rowcount
        on_deleted(n)
        return n

    # the first young row by id (ids grow with time): no scan of the old rows' bodies
    young = con.execute(
        "SELECT id FROM events WHERE t >= ? ORDER BY id LIMIT 1",
        (time.time() - max_age,),
    ).fetchone()
    low = con.execute("SELECT min(id) FROM events").fetchone()[0]
    if low is not None:
        end = young[0] if young else low + RETAIN_STEP + 1
        cut = min(end - 1, low + RETAIN_STEP - 1)
        if cut >= low:
            deleted += delete(cut)
            more = cut < end - 1
    budget = RETAIN_STEP - deleted
    while not more and live_size(con) > max_bytes:
        n = con.execute("SELECT count(*) FROM events").fetchone()[0]
        if not n:
            break
        if budget <= 0:
            more = True
            break
        step = min(max(n // 10, 1), budget)
        cut = con.execute(
            "SELECT id FROM events ORDER BY id LIMIT 1 OFFSET ?", (step - 1,)
        ).fetchone()[0]
        delete(cut)
        budget -= step
    if not more:
        con.execute("DELETE FROM skips WHERE t < ?", (time.time() - max_age,))
        free = con.execute("PRAGMA freelist_count").fetchone()[0]
        if free > RESERVE_PAGES:  # the rest of the freed pages go back to the disk
            # (executescript: a cursor would step it once, one page)
            con.executescript(f"PRAGMA incremental_vacuum({free - RESERVE_PAGES});")
    return more


def live_size(con) -> int:
    """Bytes in use by live pages (the file may be larger until vacuumed)."""
    pages = con.execute("PRAGMA page_count").fetchone()[0]
    free = con.execute("PRAGMA freelist_count").fetchone()[0]
    return (pages - free) * con.execute("PRAGMA page_size").fetchone()[0]
