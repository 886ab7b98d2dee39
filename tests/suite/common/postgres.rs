//! A PostgreSQL server for the tests that need one whatever the suite's
//! engine (several processes sharing one database): the server
//! `SINSCAL_TEST_DATABASE_URL` names, else a throwaway cluster of this
//! test binary's own, made by `pg_virtualenv` (PostgreSQL's packages) and
//! dropped when the binary exits.

use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use super::{database_in, POSTGRES_ENV};

/// The admin URL of a PostgreSQL server the test may create databases on.
pub fn admin_url() -> String {
    static URL: OnceLock<String> = OnceLock::new();
    URL.get_or_init(|| std::env::var(POSTGRES_ENV).unwrap_or_else(|_| private_cluster()))
        .clone()
}

/// A new, empty database; its URL.
pub async fn fresh_database(prefix: &str) -> String {
    create_database(&admin_url(), prefix).await
}

/// Creates an empty database named `<prefix>_<uuid>` on the server `admin`
/// names; its URL.
pub async fn create_database(admin: &str, prefix: &str) -> String {
    use sqlx::{Connection, Executor};
    let name = format!("{prefix}_{}", uuid::Uuid::new_v4().simple());
    let mut conn = sqlx::PgConnection::connect(admin)
        .await
        .unwrap_or_else(|e| panic!("PostgreSQL at {admin}: cannot connect: {e}"));
    conn.execute(format!("CREATE DATABASE {name}").as_str())
        .await
        .unwrap_or_else(|e| panic!("PostgreSQL at {admin}: create database {name}: {e}"));
    let _ = conn.close().await;
    database_in(admin, &name)
}

/// Starts `pg_virtualenv` holding a cluster open until this process exits
/// (its shell polls our pid), and reads the connection settings it
/// exports from a file: its stdout goes nowhere, so that when this
/// process is gone its teardown (which prints) still runs to the end and
/// drops the cluster.
fn private_cluster() -> String {
    let me = std::process::id();
    let settings = std::env::temp_dir().join(format!("sinscal-pg-{me}.url"));
    let _ = std::fs::remove_file(&settings);
    let script = format!(
        "printf 'postgres://%s:%s@%s:%s/postgres\\n' \"$PGUSER\" \"$PGPASSWORD\" \"$PGHOST\" \"$PGPORT\" \
           > {0}.part && mv {0}.part {0}; \
         while kill -0 {me} 2>/dev/null; do sleep 1; done",
        settings.display()
    );
    let child = Command::new("pg_virtualenv")
        .args(["sh", "-c", &script])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| {
            panic!(
                "this test needs PostgreSQL: set {POSTGRES_ENV} to a server's URL, or install \
                 PostgreSQL's packages (pg_virtualenv, from postgresql-common): {e}"
            )
        });
    let started = Instant::now();
    let url = loop {
        if let Ok(text) = std::fs::read_to_string(&settings) {
            break text.trim().to_string();
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "pg_virtualenv started no cluster (is another one, 15/regress, running?)"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    let _ = std::fs::remove_file(&settings);
    // The child outlives this function on purpose: it ends with us.
    std::mem::forget(child);
    url
}
