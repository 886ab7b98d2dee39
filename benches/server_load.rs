//! Server benchmarks (`cargo bench --bench server_load`):
//! 1. upload → result for the 3.2 h 100 Hz run, CSV and f64le;
//! 2. sustained runs per hour with 2 workers (full-length runs);
//! 3. p50/p99 of history and repeatability reads while both workers are
//!    busy, the reads coming from a second process over loopback;
//! 4. the same reads on a database holding 10 000 calibrated runs.
//!
//! 5. (`--scale-out`, alone) on PostgreSQL: one API process that runs no
//!    job and 1, 2 and 3 `sinscal worker` processes, on a database of
//!    10 000 calibrated runs: runs/hour, and the reads' p50/p99 while the
//!    workers are busy. It needs `SINSCAL_BENCH_DATABASE_URL` (a server on
//!    which it may create a database), e.g. a throwaway cluster:
//!    `pg_virtualenv sh -c 'SINSCAL_BENCH_DATABASE_URL=postgres://$PGUSER:$PGPASSWORD@$PGHOST:$PGPORT/postgres cargo bench --bench server_load -- --scale-out'`
//!
//! The second process is this binary again, started with `load`.
//! `cargo bench --bench server_load -- --reads-only` runs part 4 alone.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::Value;
use sinscal_core::calib::ParameterEstimate;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::model::PARAMETERS;
use sinscal_server::config::Config;
use sinscal_server::server::Application;
use sinscal_server::store::{JobId, NewRun, RunFile, RunId, Store};

struct Client {
    http: reqwest::Client,
    base: String,
    token: String,
}

impl Client {
    async fn upload(&self, serial: &str, meta: &[u8], data: &Path) -> Value {
        let mut meta: Value = serde_json::from_slice(meta).unwrap();
        meta["unit_serial"] = Value::String(serial.into());
        let file = tokio::fs::File::open(data).await.unwrap();
        let body = reqwest::Body::wrap_stream(tokio_util::io::ReaderStream::new(file));
        let r = self
            .http
            .post(format!("{}/units/{serial}/runs", self.base))
            .bearer_auth(&self.token)
            .header("x-sinscal-metadata", serde_json::to_string(&meta).unwrap())
            .body(body)
            .send()
            .await
            .unwrap();
        assert!(r.status().is_success(), "{}", r.status());
        r.json().await.unwrap()
    }

    async fn wait(&self, job_id: &str) {
        loop {
            let j: Value = self
                .http
                .get(format!("{}/jobs/{job_id}", self.base))
                .bearer_auth(&self.token)
                .send()
                .await
                .unwrap()
                .json()
                .await
                .unwrap();
            match j["state"].as_str().unwrap() {
                "succeeded" => return,
                "failed" | "dead_letter" | "cancelled" => panic!("{j}"),
                _ => tokio::time::sleep(Duration::from_millis(20)).await,
            }
        }
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

/// The second process: `concurrency` loops of GET history / repeatability
/// on `serials` for `seconds`; prints one JSON line of latencies (ms).
async fn load(base: String, token: String, serials: Vec<String>, seconds: f64, concurrency: usize) {
    let http = reqwest::Client::new();
    let until = Instant::now() + Duration::from_secs_f64(seconds);
    let tasks = (0..concurrency).map(|c| {
        let (http, base, token, serials) =
            (http.clone(), base.clone(), token.clone(), serials.clone());
        tokio::spawn(async move {
            let (mut hist, mut rep) = (Vec::new(), Vec::new());
            let mut k = c;
            while Instant::now() < until {
                let serial = &serials[k % serials.len()];
                k += 7;
                for (path, out) in [
                    ("history?limit=100", &mut hist),
                    ("repeatability", &mut rep),
                ] {
                    let t = Instant::now();
                    let r = http
                        .get(format!("{base}/units/{serial}/{path}"))
                        .bearer_auth(&token)
                        .send()
                        .await
                        .unwrap();
                    assert!(r.status().is_success());
                    let _ = r.bytes().await.unwrap();
                    out.push(t.elapsed().as_secs_f64() * 1e3);
                }
            }
            (hist, rep)
        })
    });
    let (mut hist, mut rep) = (Vec::new(), Vec::new());
    for t in futures_util::future::join_all(tasks).await {
        let (h, r) = t.unwrap();
        hist.extend(h);
        rep.extend(r);
    }
    hist.sort_by(f64::total_cmp);
    rep.sort_by(f64::total_cmp);
    println!(
        "{}",
        serde_json::json!({
            "history": {"n": hist.len(), "p50_ms": percentile(&hist, 0.5), "p99_ms": percentile(&hist, 0.99)},
            "repeatability": {"n": rep.len(), "p50_ms": percentile(&rep, 0.5), "p99_ms": percentile(&rep, 0.99)},
        })
    );
}

fn run_load_process(c: &Client, serials: &[String], seconds: f64) -> std::process::Child {
    std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "load",
            &c.base,
            &c.token,
            &serials.join(","),
            &seconds.to_string(),
            "4",
        ])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

async fn seed(store: &Store, units: usize, runs_per_unit: usize, prefix: &str) {
    let mut params = BTreeMap::new();
    let t0 = 1_700_000_000_000i64;
    for u in 0..units {
        let serial = format!("{prefix}-{u:04}");
        for k in 0..runs_per_unit {
            params.clear();
            for (i, p) in PARAMETERS.iter().enumerate() {
                let v = 100.0 + i as f64 + ((k * 31 + u * 7 + i) % 17) as f64 * 0.01;
                params.insert(
                    p.name.to_string(),
                    ParameterEstimate {
                        value: v,
                        sigma: 0.1,
                        unit: p.unit.to_string(),
                    },
                );
            }
            let id = RunId::new();
            let new = NewRun {
                run_id: id,
                job_id: JobId::new(),
                unit_serial: serial.parse().unwrap(),
                file: RunFile {
                    sha256: id.to_string(),
                    size_bytes: 0,
                    records: 0,
                    format: DataFormat::F64le,
                    gzip: false,
                    blob_path: format!("runs/seed/{id}.bin"),
                    metadata: String::from("{}").into(),
                },
                recorded_at: Some(t0 + (k as i64) * 86_400_000),
                uploaded_at: t0,
                max_attempts: 3,
                uploaded_by: None,
                product: None,
            };
            store.seed_calibrated_run(&new, &params).await.unwrap();
        }
    }
}

async fn start(
    dir: &Path,
    workers: usize,
) -> (
    Client,
    tokio::sync::oneshot::Sender<()>,
    tokio::task::JoinHandle<()>,
    Store,
) {
    let mut cfg = Config::new(dir);
    cfg.bind = "127.0.0.1:0".into();
    cfg.workers = workers;
    let app = Application::build(cfg).await.unwrap();
    let client = Client {
        http: reqwest::Client::new(),
        base: format!("http://{}/api/v1", app.addr()),
        token: app.first_admin_token().unwrap().to_string(),
    };
    let store = app.store();
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let task = tokio::spawn(async move {
        app.run_until_stopped(async {
            let _ = rx.await;
        })
        .await
        .unwrap()
    });
    (client, tx, task, store)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    if args.get(1).map(String::as_str) == Some("load") {
        let serials = args[4].split(',').map(String::from).collect();
        rt.block_on(load(
            args[2].clone(),
            args[3].clone(),
            serials,
            args[5].parse().unwrap(),
            args[6].parse().unwrap(),
        ));
        return;
    }
    if args.iter().any(|a| a == "--list") {
        return;
    }
    if args.iter().any(|a| a == "--scale-out") {
        rt.block_on(scale_out());
        return;
    }
    let reads_only = args.iter().any(|a| a == "--reads-only");
    rt.block_on(async {
        if !reads_only {
            timed_runs().await;
        }
        reads_on_a_large_database().await;
    });
}

/// Parts 1–3: full-length runs through the server.
async fn timed_runs() {
    let work = tempfile::tempdir().unwrap();
    eprintln!("simulating the 3.2 h run (CSV and f64le)…");
    let csv = write_simulated_run(
        &common::reference_run(),
        &work.path().join("csv"),
        DataFormat::Csv,
        false,
        "B-CSV",
    )
    .unwrap();
    let bin = write_simulated_run(
        &common::reference_run(),
        &work.path().join("bin"),
        DataFormat::F64le,
        false,
        "B-BIN",
    )
    .unwrap();
    let meta_csv = std::fs::read(&csv.metadata).unwrap();
    let meta_bin = std::fs::read(&bin.metadata).unwrap();

    let data = tempfile::tempdir().unwrap();
    let (c, stop, task, store) = start(data.path(), 2).await;

    // 1. Upload → result, one at a time.
    for (name, meta, file) in [
        ("CSV", &meta_csv, &csv.data),
        ("f64le", &meta_bin, &bin.data),
    ] {
        let size = std::fs::metadata(file).unwrap().len();
        let t = Instant::now();
        let a = c.upload(&format!("LAT-{name}"), meta, file).await;
        let uploaded = t.elapsed().as_secs_f64();
        c.wait(a["job_id"].as_str().unwrap()).await;
        println!(
            "upload→result, 3.2 h 100 Hz {name} ({:.0} MB): {:.2} s (upload {uploaded:.2} s)",
            size as f64 / 1e6,
            t.elapsed().as_secs_f64()
        );
    }

    // 2 + 3. Eight full runs queued at once on 2 workers; while they
    // run, a second process reads history and repeatability.
    seed(&store, 20, 50, "HIST").await;
    let serials: Vec<String> = (0..20).map(|u| format!("HIST-{u:04}")).collect();
    let n = 8;
    let (seconds, reads) = sustained(&c, "THR", n, &meta_bin, &bin.data, &serials).await;
    println!(
        "sustained: {n} runs (3.2 h, f64le) in {seconds:.1} s on 2 workers = {:.0} runs/hour",
        n as f64 * 3600.0 / seconds
    );
    println!("reads while both workers are busy (50 runs per unit, 4 concurrent clients in a second process): {reads}");
    let _ = stop.send(());
    task.await.unwrap();
}

/// Uploads `n` copies of a run (as units `<prefix>-<k>`) at once and waits
/// for every result while a second process reads `serials`' history and
/// repeatability (no reads if `serials` is empty); the seconds from the
/// first upload to the last result, and the reads' figures.
async fn sustained(
    c: &Client,
    prefix: &str,
    n: usize,
    meta: &[u8],
    data: &Path,
    serials: &[String],
) -> (f64, String) {
    let t = Instant::now();
    let mut jobs = Vec::new();
    for k in 0..n {
        jobs.push(c.upload(&format!("{prefix}-{k}"), meta, data).await);
    }
    let loader = (!serials.is_empty()).then(|| run_load_process(c, serials, 8.0));
    for j in &jobs {
        c.wait(j["job_id"].as_str().unwrap()).await;
    }
    let seconds = t.elapsed().as_secs_f64();
    let reads = match loader {
        Some(l) => {
            let out = l.wait_with_output().unwrap();
            String::from_utf8_lossy(&out.stdout).trim().to_string()
        }
        None => String::new(),
    };
    (seconds, reads)
}

/// Part 4: a database holding 10 000 calibrated runs.
async fn reads_on_a_large_database() {
    let big = tempfile::tempdir().unwrap();
    let (c, stop, task, store) = start(big.path(), 2).await;
    let t = Instant::now();
    seed(&store, 100, 100, "DB").await;
    eprintln!("seeded 10 000 runs in {:.1} s", t.elapsed().as_secs_f64());
    let serials: Vec<String> = (0..100).map(|u| format!("DB-{u:04}")).collect();
    let out = run_load_process(&c, &serials, 5.0)
        .wait_with_output()
        .unwrap();
    println!(
        "reads on 10 000 runs (100 units × 100 runs, idle workers, second process): {}",
        String::from_utf8_lossy(&out.stdout).trim()
    );
    let t = Instant::now();
    seed(&store, 1, 10_000, "ONE").await;
    eprintln!(
        "seeded 10 000 more runs for one unit in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    let out = run_load_process(&c, &["ONE-0000".to_string()], 5.0)
        .wait_with_output()
        .unwrap();
    println!("reads of one unit holding 10 000 runs (history page of 100; repeatability over all 10 000): {}", String::from_utf8_lossy(&out.stdout).trim());
    let _ = stop.send(());
    task.await.unwrap();
}

/// A `sinscal serve --workers 0` or `sinscal worker` process of part 5.
struct Process(std::process::Child);

impl Process {
    /// Starts `command` on `database_url`; returns it, its address and the
    /// admin token if this start made one. The caller owns the child and
    /// waits for it ([`Process::stop`]).
    #[allow(clippy::zombie_processes)]
    fn start(command: &str, data: &Path, database_url: &str) -> (Process, String, Option<String>) {
        use std::io::BufRead;
        let workers = if command == "serve" { "0" } else { "1" };
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_sinscal"))
            .args([command, "--bind", "127.0.0.1:0", "--workers", workers])
            .arg("--data-dir")
            .arg(data)
            .args(["--database-url", database_url])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
        let mut token = None;
        loop {
            let line = lines
                .next()
                .expect("the process printed its address")
                .unwrap();
            if let Some(t) = line.strip_prefix("admin token (shown once, store it now): ") {
                token = Some(t.to_string());
            }
            if let Some((_, addr)) = line.split_once(" listening on ") {
                return (Process(child), addr.to_string(), token);
            }
        }
    }

    fn stop(mut self) {
        // SAFETY: signalling our own child by its pid.
        unsafe { libc::kill(self.0.id() as i32, libc::SIGTERM) };
        let _ = self.0.wait();
    }
}

/// Part 5: the same server split into processes on PostgreSQL.
async fn scale_out() {
    use sqlx::{Connection, Executor};
    let admin = std::env::var("SINSCAL_BENCH_DATABASE_URL")
        .expect("--scale-out needs SINSCAL_BENCH_DATABASE_URL (see the head of this file)");
    let name = format!("sinscal_bench_{}", uuid::Uuid::new_v4().simple());
    let mut conn = sqlx::PgConnection::connect(&admin).await.unwrap();
    conn.execute(format!("CREATE DATABASE {name}").as_str())
        .await
        .unwrap();
    let _ = conn.close().await;
    let (root, _) = admin.rsplit_once('/').unwrap();
    let url = format!("{root}/{name}");

    let work = tempfile::tempdir().unwrap();
    eprintln!("simulating the 3.2 h run (f64le)…");
    let bin = write_simulated_run(
        &common::reference_run(),
        &work.path().join("bin"),
        DataFormat::F64le,
        false,
        "B-BIN",
    )
    .unwrap();
    let meta_bin = std::fs::read(&bin.metadata).unwrap();
    let data = tempfile::tempdir().unwrap();
    let (api, addr, token) = Process::start("serve", data.path(), &url);
    let c = Client {
        http: reqwest::Client::new(),
        base: format!("{addr}/api/v1"),
        token: token.expect("a fresh database makes an admin token"),
    };
    let store = Store::connect(
        &sinscal_server::store::DatabaseUrl::Postgres(url.clone()),
        2,
    )
    .await
    .unwrap();
    let t = Instant::now();
    seed(&store, 100, 100, "DB").await;
    eprintln!(
        "seeded 10 000 runs on PostgreSQL in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    store.close().await;
    let serials: Vec<String> = (0..100).map(|u| format!("DB-{u:04}")).collect();
    let idle = run_load_process(&c, &serials, 5.0)
        .wait_with_output()
        .unwrap();
    println!(
        "PostgreSQL, reads on 10 000 runs, no worker running (4 clients, second process): {}",
        String::from_utf8_lossy(&idle.stdout).trim()
    );
    let n = 8;
    for workers in 1..=3 {
        let processes: Vec<Process> = (0..workers)
            .map(|_| Process::start("worker", data.path(), &url).0)
            .collect();
        // First alone, then with a second process reading as fast as its
        // four clients can: on two cores, the reads (and PostgreSQL
        // answering them) take CPU from the workers.
        let prefix = format!("ALONE{workers}");
        let (seconds, _) = sustained(&c, &prefix, n, &meta_bin, &bin.data, &[]).await;
        println!(
            "PostgreSQL, {workers} worker process(es), no reads: {n} runs (3.2 h, f64le) in {seconds:.1} s = {:.0} runs/hour",
            n as f64 * 3600.0 / seconds
        );
        let prefix = format!("THR{workers}");
        let (seconds, reads) = sustained(&c, &prefix, n, &meta_bin, &bin.data, &serials).await;
        println!(
            "PostgreSQL, {workers} worker process(es), with reads: {n} runs (3.2 h, f64le) in {seconds:.1} s = {:.0} runs/hour",
            n as f64 * 3600.0 / seconds
        );
        println!("  reads on 10 000 runs meanwhile (4 clients, second process): {reads}");
        for p in processes {
            p.stop();
        }
    }
    api.stop();
}
