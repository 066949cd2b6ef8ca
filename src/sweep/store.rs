//! A sweep's results store: one SQLite file (WAL), chosen over an Arrow/Parquet dataset
//! because a transaction per job group makes a killed run lose only the jobs in flight and
//! a re-run skip what is done, one file is easy to copy off a cluster node and merge, and
//! pandas reads it with Python's own `sqlite3` (`pd.read_sql("select * from frames", con)`).
//!
//! Tables: `meta` (spec hash, shard), `jobs` (one row per job: trace, preset, point, options
//! hash, frames, wall time) and `frames` (one row per job, frame and view: `frames.csv`'s
//! columns, then `opt_NAME` for each option the point sets). Counter columns are added as
//! runs report them, so a new stage or traffic class needs no schema change.

use std::path::Path;

use rusqlite::{params, Connection, OptionalExtension};

use crate::commands::summary::Cell;

pub struct Store {
    conn: Connection,
    path: String,
}

/// A finished job's rows, as [`Store::commit`] writes them.
pub struct JobRows {
    pub key: String,
    /// Position of the job in the spec's expansion (rows are exported in this order).
    pub index: u64,
    pub trace: String,
    pub trace_hash: String,
    pub preset: String,
    pub point: String,
    pub options_hash: String,
    pub frames: String,
    pub wall_s: f64,
    pub header: Vec<String>,
    pub rows: Vec<Vec<Cell>>,
}

/// Columns every store's `frames` table starts with; the job's own come after.
const KEY_COLUMNS: &str = "job TEXT NOT NULL, job_index INTEGER NOT NULL, trace TEXT NOT NULL, point TEXT NOT NULL, \
     preset TEXT NOT NULL, frame INTEGER NOT NULL, eye TEXT NOT NULL";

impl Store {
    /// Opens (or creates) the store at `path` for the spec with hash `spec_hash`; refuses a
    /// store written for another spec.
    pub fn open(path: &Path, spec_hash: &str) -> Result<Store, String> {
        let name = path.display().to_string();
        let fail = |e: rusqlite::Error| format!("{name}: {e}");
        let conn = Connection::open(path).map_err(fail)?;
        conn.pragma_update(None, "journal_mode", "WAL").map_err(fail)?;
        conn.execute_batch(&format!(
            "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
             CREATE TABLE IF NOT EXISTS jobs (job TEXT PRIMARY KEY, job_index INTEGER NOT NULL, trace TEXT NOT NULL,
                 trace_hash TEXT NOT NULL, preset TEXT NOT NULL, point TEXT NOT NULL, options_hash TEXT NOT NULL,
                 frames TEXT NOT NULL, wall_s REAL NOT NULL);
             CREATE TABLE IF NOT EXISTS frames ({KEY_COLUMNS}, PRIMARY KEY (job, frame, eye));"
        ))
        .map_err(fail)?;
        let store = Store { conn, path: name };
        match store.spec_hash()? {
            Some(existing) if existing != spec_hash => Err(format!(
                "{}: written for another spec (hash {}, this spec {}); use another --out",
                store.path,
                &existing[..12.min(existing.len())],
                &spec_hash[..12.min(spec_hash.len())]
            )),
            Some(_) => Ok(store),
            None => {
                store
                    .conn
                    .execute("INSERT INTO meta (key, value) VALUES ('spec_hash', ?1)", [spec_hash])
                    .map_err(|e| store.fail(e))?;
                Ok(store)
            }
        }
    }

    /// Opens an existing store read-only enough for merging and reports (no spec check).
    pub fn open_existing(path: &Path) -> Result<Store, String> {
        if !path.is_file() {
            return Err(format!("{}: no such store", path.display()));
        }
        let name = path.display().to_string();
        let conn = Connection::open(path).map_err(|e| format!("{name}: {e}"))?;
        let store = Store { conn, path: name };
        store
            .spec_hash()?
            .ok_or_else(|| format!("{}: not a sweep store", store.path))?;
        Ok(store)
    }

    fn fail(&self, e: rusqlite::Error) -> String {
        format!("{}: {e}", self.path)
    }

    pub fn spec_hash(&self) -> Result<Option<String>, String> {
        let has_meta: bool = self
            .conn
            .query_row(
                "SELECT count(*) > 0 FROM sqlite_master WHERE type = 'table' AND name = 'meta'",
                [],
                |r| r.get(0),
            )
            .map_err(|e| self.fail(e))?;
        if !has_meta {
            return Ok(None);
        }
        self.conn
            .query_row("SELECT value FROM meta WHERE key = 'spec_hash'", [], |r| r.get(0))
            .optional()
            .map_err(|e| self.fail(e))
    }

    /// Whether the job `key` has finished (its rows are in the store).
    pub fn has_job(&self, key: &str) -> Result<bool, String> {
        self.conn
            .query_row("SELECT count(*) > 0 FROM jobs WHERE job = ?1", [key], |r| r.get(0))
            .map_err(|e| self.fail(e))
    }

    fn columns(&self, table: &str) -> Result<Vec<String>, String> {
        let mut stmt = self
            .conn
            .prepare(&format!("SELECT name FROM pragma_table_info('{table}') ORDER BY cid"))
            .map_err(|e| self.fail(e))?;
        let names = stmt
            .query_map([], |r| r.get(0))
            .map_err(|e| self.fail(e))?
            .collect::<Result<Vec<String>, _>>()
            .map_err(|e| self.fail(e));
        names
    }

    /// Adds the `frames` columns in `wanted` that the table lacks.
    fn add_columns(&self, wanted: &[String]) -> Result<(), String> {
        let have = self.columns("frames")?;
        for column in wanted.iter().filter(|c| !have.contains(c)) {
            self.conn
                .execute(&format!("ALTER TABLE frames ADD COLUMN {}", quote(column)), [])
                .map_err(|e| self.fail(e))?;
        }
        Ok(())
    }

    /// Writes the jobs of one group and their rows in one transaction: all or nothing.
    pub fn commit(&mut self, jobs: &[JobRows], option_values: &[(String, String)]) -> Result<(), String> {
        for job in jobs {
            let mut wanted = job.header.clone();
            wanted.extend(option_values.iter().map(|(k, _)| option_column(k)));
            self.add_columns(&wanted)?;
        }
        let path = self.path.clone();
        let fail = |e: rusqlite::Error| format!("{path}: {e}");
        let tx = self.conn.transaction().map_err(fail)?;
        for job in jobs {
            tx.execute(
                "INSERT INTO jobs (job, job_index, trace, trace_hash, preset, point, options_hash, frames, wall_s)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                params![
                    job.key,
                    job.index as i64,
                    job.trace,
                    job.trace_hash,
                    job.preset,
                    job.point,
                    job.options_hash,
                    job.frames,
                    job.wall_s
                ],
            )
            .map_err(fail)?;
            // The job's own columns (preset and frame are among them), then the options.
            let mut columns: Vec<String> = ["job", "job_index", "trace", "point"].map(String::from).to_vec();
            columns.extend(job.header.iter().cloned());
            columns.extend(option_values.iter().map(|(k, _)| option_column(k)));
            let sql = format!(
                "INSERT INTO frames ({}) VALUES ({})",
                columns.iter().map(|c| quote(c)).collect::<Vec<_>>().join(", "),
                (1..=columns.len())
                    .map(|i| format!("?{i}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            let mut stmt = tx.prepare(&sql).map_err(fail)?;
            for row in &job.rows {
                let mut values: Vec<rusqlite::types::Value> = vec![
                    job.key.clone().into(),
                    (job.index as i64).into(),
                    job.trace.clone().into(),
                    job.point.clone().into(),
                ];
                values.extend(row.iter().map(sql_value));
                values.extend(option_values.iter().map(|(_, v)| option_value(v)));
                stmt.execute(rusqlite::params_from_iter(values)).map_err(fail)?;
            }
        }
        tx.commit().map_err(fail)
    }

    /// Copies every job and row of `other` that this store lacks (idempotent); both must come
    /// from the same spec.
    pub fn merge_from(&mut self, other: &Path) -> Result<u64, String> {
        let source = Store::open_existing(other)?;
        if source.spec_hash()? != self.spec_hash()? {
            return Err(format!("{}: written for another spec than {}", source.path, self.path));
        }
        let columns = source.columns("frames")?;
        self.add_columns(&columns)?;
        drop(source);
        let list = columns.iter().map(|c| quote(c)).collect::<Vec<_>>().join(", ");
        let path = self.path.clone();
        let fail = |e: rusqlite::Error| format!("{path}: {e}");
        self.conn
            .execute("ATTACH DATABASE ?1 AS source", [other.display().to_string()])
            .map_err(fail)?;
        let tx = self.conn.transaction().map_err(fail)?;
        let jobs = tx
            .execute("INSERT OR IGNORE INTO jobs SELECT * FROM source.jobs", [])
            .map_err(fail)?;
        tx.execute(
            &format!("INSERT OR IGNORE INTO frames ({list}) SELECT {list} FROM source.frames"),
            [],
        )
        .map_err(fail)?;
        tx.commit().map_err(fail)?;
        self.conn.execute("DETACH DATABASE source", []).map_err(fail)?;
        Ok(jobs as u64)
    }

    /// Every `frames` row in spec order, as (column names, rows of optional SQL values).
    pub fn frame_table(&self) -> Result<(Vec<String>, Vec<Vec<rusqlite::types::Value>>), String> {
        let columns = self.columns("frames")?;
        let mut stmt = self
            .conn
            .prepare("SELECT * FROM frames ORDER BY job_index, frame, eye")
            .map_err(|e| self.fail(e))?;
        let rows = stmt
            .query_map([], |r| (0..columns.len()).map(|i| r.get(i)).collect())
            .map_err(|e| self.fail(e))?
            .collect::<Result<Vec<Vec<rusqlite::types::Value>>, _>>()
            .map_err(|e| self.fail(e))?;
        Ok((columns, rows))
    }

    pub fn job_count(&self) -> Result<u64, String> {
        self.conn
            .query_row("SELECT count(*) FROM jobs", [], |r| r.get::<_, i64>(0))
            .map(|n| n as u64)
            .map_err(|e| self.fail(e))
    }

    /// Writes the `frames` table as CSV at `path` (atomically).
    pub fn export_csv(&self, path: &Path) -> Result<(), String> {
        let (columns, rows) = self.frame_table()?;
        let fail = |e: csv::Error| format!("{}: {e}", path.display());
        shadetrace_formats::atomic_file::write_atomically(path, |w| {
            let mut csv = csv::Writer::from_writer(w);
            csv.write_record(&columns).map_err(fail)?;
            for row in rows {
                csv.write_record(row.iter().map(csv_text)).map_err(fail)?;
            }
            csv.flush().map_err(|e| format!("{}: {e}", path.display()))
        })
    }
}

/// The store column of a point's option (`texture-cache-kb` -> `opt_texture_cache_kb`).
pub fn option_column(option: &str) -> String {
    format!("opt_{}", option.replace('-', "_"))
}

/// A column name as an SQL identifier.
fn quote(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

fn sql_value(cell: &Cell) -> rusqlite::types::Value {
    use rusqlite::types::Value;
    match cell {
        Cell::Int(v) => Value::Integer(*v),
        Cell::Real(v) => Value::Real(*v),
        Cell::Text(v) => Value::Text(v.clone()),
        Cell::Empty => Value::Null,
    }
}

/// An option's value as a number where it is one (so pandas can sort and plot it).
fn option_value(text: &str) -> rusqlite::types::Value {
    use rusqlite::types::Value;
    match (text.parse::<i64>(), text.parse::<f64>()) {
        (Ok(i), _) => Value::Integer(i),
        (_, Ok(f)) if f.is_finite() => Value::Real(f),
        _ => Value::Text(text.to_string()),
    }
}

/// A stored value as CSV text, as `frames.csv` writes it.
pub fn csv_text(value: &rusqlite::types::Value) -> String {
    use rusqlite::types::Value;
    match value {
        Value::Null => String::new(),
        Value::Integer(v) => v.to_string(),
        Value::Real(v) => v.to_string(),
        Value::Text(v) => v.clone(),
        Value::Blob(_) => "<blob>".to_string(),
    }
}
