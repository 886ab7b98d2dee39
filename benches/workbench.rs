//! Workbench page benchmark (`cargo bench --bench workbench`): the unit
//! page of a unit with 100 calibrated runs (history, repeatability table,
//! 24 trend charts with a tolerance band, all inlined), the units page of
//! a line with 1000 units, and the run page of a real calibration of the
//! paper's 9+9 scheme (7 convergence charts of its 500-point history, the
//! residual chart), each requested over loopback by a signed-in session,
//! one request at a time: p50, p99 and max of the whole request (query,
//! render, transfer) over 300 requests after 20 to warm up.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use reqwest::header::{COOKIE, SET_COOKIE};
use sinscal_core::accept::{LimitKind, ProductLimits};
use sinscal_core::calib::ParameterEstimate;
use sinscal_core::io::data::DataFormat;
use sinscal_core::io::run::write_simulated_run;
use sinscal_core::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal_core::nav::Site;
use sinscal_core::sim::{Noise, Scheme, SimConfig};
use sinscal_server::config::Config;
use sinscal_server::jobs::JobRunner;
use sinscal_server::server::Application;
use sinscal_server::store::{JobId, NewRun, ProductTypeChange, RunFile, RunId, Store};

const RUNS: usize = 100;
const UNITS: usize = 1000;
const WARMUP: usize = 20;
const REQUESTS: usize = 300;

fn new_run(serial: &str, k: usize) -> NewRun {
    let id = RunId::new();
    NewRun {
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
        recorded_at: Some(1_700_000_000_000 + k as i64 * 86_400_000),
        uploaded_at: 1_700_000_000_000,
        max_attempts: 3,
        uploaded_by: None,
        product: Some("NAV-1".into()),
    }
}

/// Values near the paper's truth with a run-to-run scatter, σ as a
/// navigation-grade calibration reports them.
fn parameters(k: usize) -> BTreeMap<String, ParameterEstimate> {
    PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let scatter = (((k * 37 + i * 11) % 23) as f64 - 11.0) / 11.0;
            (
                p.name.to_string(),
                ParameterEstimate {
                    value: 100.0 + i as f64 + scatter,
                    sigma: 0.3,
                    unit: p.unit.to_string(),
                },
            )
        })
        .collect()
}

async fn seed(store: &Store) {
    let mut limits = ProductLimits::default();
    for p in PARAMETERS.iter() {
        limits.set(p.name, LimitKind::MaxAbsValue, 150.0).unwrap();
        limits
            .set(p.name, LimitKind::MaxRepeatability, 2.0)
            .unwrap();
    }
    store
        .create_product_type(ProductTypeChange {
            name: "NAV-1",
            description: Some("benchmark"),
            limits: &limits,
            model: None,
            by: "bench",
        })
        .await
        .unwrap();
    for k in 0..RUNS {
        store
            .seed_calibrated_run(&new_run("RLG-BENCH", k), &parameters(k))
            .await
            .unwrap();
    }
    for u in 0..UNITS {
        let serial = format!("RLG-{u:05}");
        store
            .seed_calibrated_run(&new_run(&serial, 0), &parameters(u))
            .await
            .unwrap();
    }
}

async fn sign_in(origin: &str, token: &str) -> (reqwest::Client, String) {
    let http = reqwest::Client::builder()
        .redirect(reqwest::redirect::Policy::none())
        .build()
        .unwrap();
    let form = http.get(format!("{origin}/signin")).send().await.unwrap();
    let cookie = form.headers()[SET_COOKIE].to_str().unwrap();
    let cookie = cookie.split(';').next().unwrap().to_string();
    let html = form.text().await.unwrap();
    let at = html.find("name=\"form_token\" value=\"").unwrap() + 25;
    let form_token: String = html[at..].chars().take_while(|c| *c != '"').collect();
    let r = http
        .post(format!("{origin}/signin"))
        .header(COOKIE, cookie)
        .form(&[("token", token), ("form_token", form_token.as_str())])
        .send()
        .await
        .unwrap();
    let session = r
        .headers()
        .get_all(SET_COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .find(|v| v.starts_with("sinscal_session="))
        .unwrap()
        .split(';')
        .next()
        .unwrap()
        .to_string();
    (http, session)
}

fn quantile(sorted: &[Duration], q: f64) -> Duration {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

async fn measure(http: &reqwest::Client, cookie: &str, url: &str, needle: &str) {
    let mut times = Vec::with_capacity(REQUESTS);
    let mut bytes = 0;
    for i in 0..WARMUP + REQUESTS {
        let start = Instant::now();
        let r = http.get(url).header(COOKIE, cookie).send().await.unwrap();
        assert_eq!(r.status(), reqwest::StatusCode::OK, "{url}");
        let body = r.text().await.unwrap();
        let took = start.elapsed();
        assert!(body.contains(needle), "{url} lacks {needle}");
        bytes = body.len();
        if i >= WARMUP {
            times.push(took);
        }
    }
    times.sort();
    println!(
        "{url}: {} kB; p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms over {REQUESTS} requests",
        bytes / 1024,
        quantile(&times, 0.5).as_secs_f64() * 1e3,
        quantile(&times, 0.99).as_secs_f64() * 1e3,
        times.last().unwrap().as_secs_f64() * 1e3,
    );
}

/// Simulates the paper's 9+9 scheme (2 min dwells), uploads it and runs
/// its calibration job; the run's id.
async fn calibrated_run(
    addr: std::net::SocketAddr,
    runner: &JobRunner,
    token: &str,
    dir: &std::path::Path,
) -> String {
    let cfg = SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 100.0,
        scheme: Scheme::builtin("ten-position-9+9", 120.0).unwrap(),
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise: Noise {
            gyro_arw_deg_rt_h: 0.0003,
            accel_vrw_ug_rt_hz: 5.0,
            ..Noise::default()
        },
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed: 1,
        thermal: None,
        temperature: None,
    };
    let files = write_simulated_run(&cfg, dir, DataFormat::F64le, false, "RLG-RUN").unwrap();
    let form = reqwest::multipart::Form::new()
        .part(
            "metadata",
            reqwest::multipart::Part::bytes(std::fs::read(&files.metadata).unwrap()),
        )
        .part(
            "data",
            reqwest::multipart::Part::bytes(std::fs::read(&files.data).unwrap()),
        );
    let r = reqwest::Client::new()
        .post(format!("http://{addr}/api/v1/units/RLG-RUN/runs"))
        .bearer_auth(token)
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), reqwest::StatusCode::ACCEPTED);
    let up: serde_json::Value = r.json().await.unwrap();
    runner.try_run_next_job(0).await.unwrap();
    up["run_id"].as_str().unwrap().to_string()
}

#[tokio::main]
async fn main() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = Config::new(dir.path());
    cfg.bind = "127.0.0.1:0".into();
    cfg.workers = 0;
    let app = Application::build(cfg).await.unwrap();
    let token = app.first_admin_token().unwrap().to_string();
    let origin = format!("http://{}", app.addr());
    let (addr, runner) = (app.addr(), app.runner());
    let t = Instant::now();
    seed(&app.store()).await;
    println!(
        "seeded {RUNS} runs of one unit and {UNITS} other units in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(async move {
        app.run_until_stopped(async {
            let _ = stopped.await;
        })
        .await
        .unwrap();
    });
    let run_id = calibrated_run(addr, &runner, &token, dir.path()).await;
    let (http, cookie) = sign_in(&origin, &token).await;
    measure(
        &http,
        &cookie,
        &format!("{origin}/units/RLG-BENCH"),
        "id=\"repeatability\"",
    )
    .await;
    measure(
        &http,
        &cookie,
        &format!("{origin}/units/RLG-BENCH?columns=all"),
        "id=\"trends\"",
    )
    .await;
    measure(&http, &cookie, &format!("{origin}/"), "id=\"units\"").await;
    measure(
        &http,
        &cookie,
        &format!("{origin}/runs/{run_id}"),
        "id=\"convergence\"",
    )
    .await;
    let _ = stop.send(());
    let _ = server.await;
}
