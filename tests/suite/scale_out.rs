//! Scale-out on PostgreSQL: API servers that run no jobs (`serve
//! --workers 0`) and workers that answer no client (`sinscal worker`), all
//! separate processes sharing one database and one run store. Uploads
//! arrive from concurrent clients while random processes are killed with
//! SIGKILL and restarted; afterwards every acknowledged run is calibrated
//! exactly once, to the result of calibrating its file directly, every run
//! row has its file, and no job ran to completion twice.

use crate::common;

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::*;
use rand::{Rng, SeedableRng};
use serde_json::Value;
use sinscal_core::io::data::DataFormat;

/// What a process of the deployment is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Api,
    Worker,
}

/// One process of the deployment.
struct Member {
    kind: Kind,
    process: process::Process,
}

/// The settings every process of the deployment shares.
#[derive(Clone)]
struct Deployment {
    /// The data folder: one shared by every process (runs kept in it), or,
    /// with an object store, one per process under this folder (as on
    /// separate machines).
    data_dir: PathBuf,
    database_url: String,
    logs: PathBuf,
    /// `--run-store s3://…` and the environment that reaches the store.
    object_store: Option<(String, Vec<(&'static str, String)>)>,
}

impl Deployment {
    /// Starts a process; returns it with the admin token if this start
    /// created the first one.
    fn start(&self, kind: Kind, index: usize) -> (Member, Option<String>) {
        let (command, workers) = match kind {
            Kind::Api => ("serve", "0"),
            Kind::Worker => ("worker", "1"),
        };
        let log = self.logs.join(format!("{command}-{index}.log"));
        let mut cmd = process::sinscal(&[command, "--bind", "127.0.0.1:0", "--workers", workers]);
        cmd.args(["--lease-secs", "1", "--max-attempts", "50"])
            .args(["--database-url", &self.database_url])
            .env("RUST_LOG", "info,sqlx=warn");
        match &self.object_store {
            None => cmd.arg("--data-dir").arg(&self.data_dir),
            Some((run_store, env)) => cmd
                .arg("--data-dir")
                .arg(self.data_dir.join(format!("{command}-{index}")))
                .args(["--run-store", run_store])
                .envs(env.iter().map(|(k, v)| (*k, v.as_str()))),
        };
        let (process, token) = process::Process::start(cmd, &log);
        (Member { kind, process }, token)
    }
}

impl Member {
    fn sigterm(self) {
        let status = self.process.sigterm();
        assert!(status.success(), "{:?} exited with {status}", self.kind);
    }
}

/// An acknowledged upload.
#[derive(Clone, Debug)]
struct Acked {
    run_id: String,
    job_id: String,
}

/// The deployment the issue describes: PostgreSQL and an S3-compatible
/// store, every process with its own data folder.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn on_postgres_and_s3_two_servers_three_workers_ten_sigkills_lose_nothing() {
    let s3 = s3::S3Server::start().await;
    let bucket = s3.create_bucket("scale").await;
    let client = s3.client(&bucket);
    let store = (format!("s3://{bucket}/line-1"), s3.env());
    let has_object = |keys: Vec<String>| move |blob: &str| keys.contains(&format!("line-1/{blob}"));
    chaos(Some(store), async move {
        has_object(client.keys("line-1/runs").await)
    })
    .await;
}

/// The same on one machine whose processes share a data folder for runs.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn on_postgres_and_a_shared_folder_the_same_holds() {
    chaos(None, async { |_: &str| true }).await;
}

/// 2 API servers and 3 workers, 50 uploads from 8 clients, 10 SIGKILLs of
/// random processes (each restarted); then the checks of the module's head.
/// `objects` lists the object store once everything is done, as a test of
/// whether a blob path has its object (the shared folder is checked on
/// disk).
async fn chaos<F, P>(object_store: Option<(String, Vec<(&'static str, String)>)>, objects: F)
where
    F: std::future::Future<Output = P>,
    P: Fn(&str) -> bool,
{
    const UPLOADS: usize = 50;
    const CLIENTS: usize = 8;
    const KILLS: usize = 10;
    let data = tempfile::tempdir().unwrap();
    let logs = tempfile::tempdir().unwrap();
    let shared_folder = object_store.is_none();
    let deployment = Deployment {
        data_dir: data.path().to_path_buf(),
        database_url: postgres::fresh_database("sinscal_scale").await,
        logs: logs.path().to_path_buf(),
        object_store,
    };
    // The first API server migrates the database and makes the token.
    let (api0, token) = deployment.start(Kind::Api, 0);
    let token = token.expect("first start makes an admin token");
    let mut processes = vec![api0];
    processes.push(deployment.start(Kind::Api, 1).0);
    for w in 0..3 {
        processes.push(deployment.start(Kind::Worker, w).0);
    }
    let apis: Arc<Mutex<Vec<String>>> = Arc::new(Mutex::new(
        processes
            .iter()
            .filter(|p| p.kind == Kind::Api)
            .map(|p| p.process.addr.clone())
            .collect(),
    ));

    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 21, DataFormat::Csv, "RLG-0042");
    let csv = std::fs::read(&run.data).unwrap();
    let http = reqwest::Client::new();
    let next = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let acked: Arc<Mutex<Vec<Acked>>> = Arc::default();
    let mut clients = Vec::new();
    for c in 0..CLIENTS {
        let (http, token, apis, next, acked) = (
            http.clone(),
            token.clone(),
            apis.clone(),
            next.clone(),
            acked.clone(),
        );
        let (csv, meta) = (csv.clone(), run.metadata.clone());
        clients.push(tokio::spawn(async move {
            let mut tries = 0usize;
            loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                if k >= UPLOADS {
                    return tries;
                }
                // A comment makes every upload's bytes distinct.
                let mut body = format!("# upload {k}\n").into_bytes();
                body.extend_from_slice(&csv);
                // Until acknowledged: a killed server's upload is sent again
                // (to either server); the same bytes are one run.
                for attempt in 0.. {
                    tries += 1;
                    let addr = {
                        let apis = apis.lock().unwrap();
                        apis[(c + attempt) % apis.len()].clone()
                    };
                    let api = format!("{addr}/api/v1");
                    match process::upload_run(&http, &api, &token, "RLG-0042", &meta, body.clone())
                        .await
                    {
                        Ok(r) if r.status() == 202 || r.status() == 200 => {
                            let v: Value = r.json().await.unwrap();
                            acked.lock().unwrap().push(Acked {
                                run_id: v["run_id"].as_str().unwrap().into(),
                                job_id: v["job_id"].as_str().unwrap().into(),
                            });
                            break;
                        }
                        Ok(r) if r.status() == 503 => {}
                        Ok(r) => panic!("upload answered {}: {:?}", r.status(), r.text().await),
                        Err(_) => {}
                    }
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
            }
        }));
    }

    // SIGKILLs at random moments on random processes, each restarted.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
    let mut killed = BTreeMap::<&str, usize>::new();
    for _ in 0..KILLS {
        tokio::time::sleep(Duration::from_millis(rng.gen_range(500..2500))).await;
        let i = rng.gen_range(0..processes.len());
        let kind = processes[i].kind;
        processes[i].process.sigkill();
        *killed
            .entry(if kind == Kind::Api { "api" } else { "worker" })
            .or_default() += 1;
        let index = i;
        let (p, _) = deployment.start(kind, index);
        if kind == Kind::Api {
            let old = processes[i].process.addr.clone();
            let mut apis = apis.lock().unwrap();
            for a in apis.iter_mut() {
                if *a == old {
                    *a = p.process.addr.clone();
                }
            }
        }
        processes[i] = p;
    }
    let mut tries = 0;
    for c in clients {
        tries += c.await.unwrap();
    }
    eprintln!("kills: {killed:?}; {tries} upload attempts for {UPLOADS} uploads");

    // Every acknowledged run's job ends, succeeded.
    let api = apis.lock().unwrap()[0].clone();
    let acked = acked.lock().unwrap().clone();
    let mut by_run: HashMap<String, Acked> = HashMap::new();
    for a in &acked {
        if let Some(prev) = by_run.insert(a.run_id.clone(), a.clone()) {
            assert_eq!(prev.job_id, a.job_id, "one job per run");
        }
    }
    assert_eq!(by_run.len(), UPLOADS, "every upload is one run");
    let started = Instant::now();
    let mut results = Vec::new();
    for a in by_run.values() {
        loop {
            let job =
                process::get_json(&http, &token, &format!("{api}/api/v1/jobs/{}", a.job_id)).await;
            if job["state"] == "succeeded" {
                break;
            }
            assert!(
                job["state"] == "queued" || job["state"] == "running",
                "{job}"
            );
            assert!(
                started.elapsed() < Duration::from_secs(600),
                "not done: {job}"
            );
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        let result = process::get_json(
            &http,
            &token,
            &format!("{api}/api/v1/runs/{}/result", a.run_id),
        )
        .await;
        results.push(result);
    }
    for p in processes {
        p.sigterm();
    }

    // The database: one run per upload, each with its file; one result each.
    let pool = sqlx::PgPool::connect(&deployment.database_url)
        .await
        .unwrap();
    let rows: Vec<(String, String)> = sqlx::query_as("SELECT id, blob_path FROM runs")
        .fetch_all(&pool)
        .await
        .unwrap();
    assert_eq!(rows.len(), UPLOADS, "no run row beyond the acknowledged");
    let has_object = objects.await;
    for (id, blob) in &rows {
        assert!(by_run.contains_key(id), "run {id} was never acknowledged");
        let whole = if shared_folder {
            data.path().join(blob).is_file()
        } else {
            has_object(blob)
        };
        assert!(whole, "run {id}: its bytes at {blob} are missing");
    }
    let n: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM results")
        .fetch_one(&pool)
        .await
        .unwrap();
    assert_eq!(n as usize, UPLOADS);
    let (jobs, queued): (i64, i64) =
        sqlx::query_as("SELECT COUNT(*), COUNT(*) FILTER (WHERE state <> 'succeeded') FROM jobs")
            .fetch_one(&pool)
            .await
            .unwrap();
    assert_eq!((jobs as usize, queued), (UPLOADS, 0));

    // No job ran to completion twice: across every worker's log, each
    // job's success is written once (a second would be a fenced write that
    // landed, or a claim of a finished job).
    let mut succeeded = HashMap::<String, usize>::new();
    for entry in std::fs::read_dir(logs.path()).unwrap() {
        let text = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        for line in text.lines() {
            if line.contains("job attempt ended") && line.contains("end=Succeeded") {
                let job = line
                    .split("job=")
                    .nth(1)
                    .and_then(|s| s.split_whitespace().next())
                    .unwrap()
                    .to_string();
                *succeeded.entry(job).or_default() += 1;
            }
        }
    }
    // A worker killed between committing a success and writing its log
    // line leaves that job's success unlogged: each worker kill may hide at
    // most one (a worker runs one job at a time), never a second success.
    let mut unlogged = 0;
    for a in by_run.values() {
        let times = succeeded.get(&a.job_id).copied().unwrap_or(0);
        assert!(times <= 1, "job {} succeeded {times} times", a.job_id);
        unlogged += usize::from(times == 0);
    }
    let worker_kills = killed.get("worker").copied().unwrap_or(0);
    assert!(
        unlogged <= worker_kills,
        "{unlogged} successes unlogged, more than the {worker_kills} worker kills explain"
    );

    // The results are the file's own: the uploads differ only by a comment.
    let direct = calibrate_directly(&run);
    for result in &results {
        for (name, p) in &direct.parameters {
            let v = result["parameters"][name]["value"].as_f64().unwrap();
            assert!(
                (v - p.value).abs() <= 1e-12 * p.value.abs().max(1e-30),
                "{name}: {v} vs {}",
                p.value
            );
        }
    }
}

/// `serve` with `--database-url`, expected to refuse to start: its exit
/// status and what it printed on stderr.
fn refused_start(database_url: &str) -> String {
    let data = tempfile::tempdir().unwrap();
    let out = process::sinscal(&["serve", "--bind", "127.0.0.1:0", "--workers", "0"])
        .arg("--data-dir")
        .arg(data.path())
        .args(["--database-url", database_url])
        .output()
        .unwrap();
    assert!(!out.status.success(), "started on {database_url}");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// An unreachable server, a refused password and a missing database each
/// stop the start with the URL (password hidden) and the reason.
#[tokio::test]
async fn a_database_that_cannot_be_used_is_named_with_the_reason() {
    let admin = postgres::admin_url();
    let (scheme_user, rest) = admin.split_once(':').unwrap();
    assert_eq!(scheme_user, "postgres");
    let unreachable = refused_start("postgres://sinscal:secret@127.0.0.1:1/sinscal");
    assert!(
        unreachable.contains("cannot open the database postgres://sinscal:***@127.0.0.1:1/sinscal")
            && unreachable.to_lowercase().contains("refused"),
        "{unreachable}"
    );
    assert!(!unreachable.contains("secret"), "{unreachable}");

    // The admin URL with another password: postgres://user:PASSWORD@host…
    let (user_part, host_part) = rest.rsplit_once('@').unwrap();
    let user = user_part.trim_start_matches('/').split(':').next().unwrap();
    let wrong = format!("postgres://{user}:not-the-password@{host_part}");
    let refused = refused_start(&wrong);
    assert!(
        refused.contains("password authentication failed") && !refused.contains("not-the-password"),
        "{refused}"
    );

    let missing = refused_start(&database_in(&admin, "no_such_database"));
    assert!(
        missing.contains("no_such_database") && missing.contains("does not exist"),
        "{missing}"
    );
}
