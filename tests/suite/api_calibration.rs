//! End to end through the real server: five runs of one unit whose truths
//! differ slightly are calibrated; history and repeatability agree with the
//! truths and with statistics computed here. Eight clients upload at once
//! and every run is calibrated exactly once.

use crate::common;
use crate::thermal_support;

use std::time::Duration;

use common::*;
use rand::{Rng, SeedableRng};
use reqwest::StatusCode;
use serde_json::Value;
use sinscal_core::io::data::DataFormat;
use sinscal_core::model::{ErrorParameters, PARAMETERS};

/// Estimates must be within this many of their own σ of the truth. The
/// estimator's σ is honest (z-scores of a few units at most on these runs),
/// so 5 leaves room without hiding a wrong result.
const Z_MAX: f64 = 5.0;

/// The paper's truth with every parameter moved by up to ±5 % (seeded):
/// a unit that drifts a little between calibrations.
fn drifted_truth(seed: u64) -> ErrorParameters {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1000 + seed);
    let mut p = ErrorParameters::paper();
    for v in p.si.iter_mut() {
        *v *= 1.0 + rng.gen_range(-0.05..0.05);
    }
    p
}

fn mean_std(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-12)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn five_runs_give_history_and_repeatability_matching_the_truths() {
    let app = spawn_app_with(2, |c| {
        c.tolerances.insert("gyro_scale_x".into(), 1.0);
        c.tolerances.insert("gyro_bias_x".into(), 1.0);
    })
    .await;
    let serial = "RLG-0042";
    let dir = tempfile::tempdir().unwrap();
    let mut runs = Vec::new();
    for k in 0..5u64 {
        // 120 s dwells of the 9+9 scheme (~45 min): accurate and quick.
        let cfg = sim_config(k + 1, drifted_truth(k), "ten-position-9+9", 120.0);
        let (format, gzip) = match k % 3 {
            0 => (DataFormat::F64le, false),
            1 => (DataFormat::Csv, false),
            _ => (DataFormat::Csv, true),
        };
        let recorded_at = format!("2026-0{}-15T08:00:00Z", k + 1);
        let run = simulate_run(
            &dir.path().join(k.to_string()),
            &cfg,
            format,
            gzip,
            serial,
            Some(&recorded_at),
        );
        let r = app.upload_run(serial, &run).await;
        assert_eq!(r.status(), StatusCode::ACCEPTED);
        let body: Value = r.json().await.unwrap();
        runs.push((body, run));
    }
    for (body, _) in &runs {
        let job = app
            .wait_job(body["job_id"].as_str().unwrap(), Duration::from_secs(120))
            .await;
        assert_eq!(job["state"], "succeeded", "{job}");
        assert_eq!(job["attempts"], 1);
        assert_eq!(job["progress_percent"], 100.0);
    }

    // History: every run, oldest first, each parameter within Z_MAX σ.
    let history = app.history(serial, "").await;
    assert_eq!(history["total"], 5);
    let items = history["items"].as_array().unwrap();
    assert_eq!(items.len(), 5);
    let mut estimates = vec![Vec::new(); PARAMETERS.len()];
    for (k, (item, (body, run))) in items.iter().zip(&runs).enumerate() {
        assert_eq!(
            item["run_id"], body["run_id"],
            "history is in recorded_at order"
        );
        assert_eq!(
            item["run_time"],
            format!("2026-0{}-15T08:00:00.000Z", k + 1)
        );
        for (i, p) in PARAMETERS.iter().enumerate() {
            let e = &item["parameters"][p.name];
            let (value, sigma) = (e["value"].as_f64().unwrap(), e["sigma"].as_f64().unwrap());
            let truth = run.truth.canonical(i);
            assert!(
                (value - truth).abs() < Z_MAX * sigma,
                "run {k} {}: estimate {value} truth {truth} σ {sigma}",
                p.name
            );
            estimates[i].push(value);
        }
        // The result endpoint has the same numbers and the convergence history.
        let result = app.get_result(body["run_id"].as_str().unwrap()).await;
        assert_eq!(result["parameters"], item["parameters"]);
        assert!(!result["convergence"]["t"].as_array().unwrap().is_empty());
    }
    // Date filters and pagination.
    let page = app
        .history(
            serial,
            "?from=2026-02-01&to=2026-04-01T00:00:00Z&limit=1&offset=1",
        )
        .await;
    assert_eq!(page["total"], 2);
    assert_eq!(page["items"][0]["run_id"], runs[2].0["run_id"]);

    // Repeatability: the server's statistics are those of the estimates,
    // and they track the truths' within the estimates' σ.
    let rep = app.repeatability(serial, "").await;
    assert_eq!(rep["runs"], 5);
    let params = rep["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 24);
    for (i, p) in PARAMETERS.iter().enumerate() {
        let s = &params[i];
        assert_eq!(s["name"], p.name, "canonical order");
        let (mean, std) = mean_std(&estimates[i]);
        assert!(close(s["mean"].as_f64().unwrap(), mean), "{}: {s}", p.name);
        assert!(
            close(s["std_dev"].as_f64().unwrap(), std),
            "{}: {s}",
            p.name
        );
        let (min, max) = estimates[i]
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(close(s["min"].as_f64().unwrap(), min) && close(s["max"].as_f64().unwrap(), max));
        assert!(close(s["range"].as_f64().unwrap(), max - min));
        let change = estimates[i]
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        assert!(
            close(s["max_change"].as_f64().unwrap(), change),
            "{}: {s} vs {change}",
            p.name
        );

        let truths: Vec<f64> = runs.iter().map(|(_, r)| r.truth.canonical(i)).collect();
        let (t_mean, t_std) = mean_std(&truths);
        let sigma = items
            .iter()
            .map(|it| it["parameters"][p.name]["sigma"].as_f64().unwrap())
            .fold(0.0, f64::max);
        assert!(
            (mean - t_mean).abs() < Z_MAX * sigma,
            "{}: mean {mean} vs truths' {t_mean}",
            p.name
        );
        assert!(
            (std - t_std).abs() < Z_MAX * sigma,
            "{}: std {std} vs truths' {t_std}",
            p.name
        );
    }
    // Tolerances (set below): 1 ppm on gyro_scale_x, whose truths spread
    // by ±25 ppm, is exceeded; 1 deg/h on gyro_bias_x is not.
    let flagged: Vec<&str> = rep["flagged"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(flagged.contains(&"gyro_scale_x"), "{flagged:?}");
    assert!(!flagged.contains(&"gyro_bias_x"), "{flagged:?}");
    assert_eq!(params[3]["tolerance"], 1.0);
    let last3 = app.repeatability(serial, "?last=3").await;
    assert_eq!(last3["runs"], 3);
    // The runs it covers, the three latest in time order, each with the
    // server's model (as the history says).
    let covered: Vec<&Value> = last3["run_models"].as_array().unwrap().iter().collect();
    assert_eq!(covered.len(), 3);
    for (c, (body, _)) in covered.iter().zip(&runs[2..]) {
        assert_eq!(c["run_id"], body["run_id"]);
        assert_eq!(c["model"], "base-24");
    }
    assert!(items.iter().all(|it| it["model"] == "base-24"));
    let since = app.repeatability(serial, "?since=2026-04-01").await;
    assert_eq!(since["runs"], 2);
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn eight_concurrent_uploads_are_each_calibrated_exactly_once() {
    let app = spawn_app(2).await;
    let dir = tempfile::tempdir().unwrap();
    let runs: Vec<SimRun> = (0..8u64)
        .map(|k| {
            let serial = format!("RLG-{:04}", 100 + k % 3);
            short_run(
                &dir.path().join(k.to_string()),
                50 + k,
                DataFormat::F64le,
                &serial,
            )
        })
        .collect();
    let station = app.create_token("station").await;
    let uploads = runs.iter().enumerate().map(|(k, run)| {
        let (app, station) = (&app, &station);
        async move {
            let serial = format!("RLG-{:04}", 100 + k as u64 % 3);
            let r = app
                .upload_multipart(
                    station,
                    &serial,
                    &run.metadata,
                    std::fs::read(&run.data).unwrap(),
                )
                .await;
            assert_eq!(r.status(), StatusCode::ACCEPTED);
            r.json::<Value>().await.unwrap()
        }
    });
    let answers = futures_util::future::join_all(uploads).await;
    for a in &answers {
        let job = app
            .wait_job(a["job_id"].as_str().unwrap(), Duration::from_secs(120))
            .await;
        assert_eq!(job["state"], "succeeded", "{job}");
        assert_eq!(job["attempts"], 1, "claimed once: {job}");
    }
    let units = app.units().await;
    assert_eq!(units["total"], 3);
    let total: i64 = units["items"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| u["calibrated"].as_i64().unwrap())
        .sum();
    assert_eq!(total, 8, "one result per run");
    // The duration histogram is updated just after the job's row commits:
    // give the last worker a moment.
    let mut metrics = app.metrics().await;
    for _ in 0..100 {
        if metrics.contains("sinscal_job_duration_seconds_count{outcome=\"succeeded\"} 8") {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
        metrics = app.metrics().await;
    }
    assert!(
        metrics.contains("sinscal_jobs{state=\"succeeded\"} 8"),
        "{metrics}"
    );
    assert!(
        metrics.contains("sinscal_job_duration_seconds_count{outcome=\"succeeded\"} 8"),
        "{metrics}"
    );
    assert!(metrics.contains("sinscal_queue_depth 0"));
    // Eight jobs, each claimed once: eight claims that found a job.
    assert!(
        metrics.contains("sinscal_claim_seconds_count{outcome=\"claimed\"} 8"),
        "{metrics}"
    );
    app.stop().await;
}

/// A line that knows its units lag: the server's `--model` reaches every
/// calibrate job, whose result carries the effect with its σ.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_configured_model_reaches_the_calibrate_jobs() {
    let app = spawn_app_with(1, |c| {
        c.estimate.model = "base+accel_delay".parse().unwrap();
    })
    .await;
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = sim_config(7, ErrorParameters::paper(), "ten-position-9+9", 60.0);
    cfg.effects.accel_delay = Some(2.0);
    let run = simulate_run(dir.path(), &cfg, DataFormat::F64le, false, "RLG-0077", None);
    let r = app.upload_run("RLG-0077", &run).await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let body: Value = r.json().await.unwrap();
    let job = app
        .wait_job(body["job_id"].as_str().unwrap(), Duration::from_secs(120))
        .await;
    assert_eq!(job["state"], "succeeded", "{job}");
    let result = app.get_result(body["run_id"].as_str().unwrap()).await;
    assert_eq!(result["model"], "base-24+accel_delay");
    let delay = &result["effects"]["accel_delay"];
    let (value, sigma) = (
        delay["value"].as_f64().unwrap(),
        delay["sigma"].as_f64().unwrap(),
    );
    assert_eq!(delay["unit"], "ms");
    assert!(
        (value - 2.0).abs() < 3.0 * sigma,
        "delay {value} ± {sigma} ms for 2"
    );
}

/// A unit's thermal model over the API and on its page: runs uploaded with
/// their soak temperature (metadata `temperature_c`) are calibrated, the
/// result and the store keep the temperature, and
/// `GET /units/{serial}/thermal` fits them (range, runs, a slope the truth
/// has within 3σ); one temperature is 409, an unknown unit 404, a station
/// 403; the unit page shows the model's table and charts.
#[tokio::test]
async fn a_unit_s_thermal_model_from_its_soaked_runs() {
    let app = spawn_app(2).await;
    let dir = tempfile::tempdir().unwrap();
    let serial = "RLG-T";
    let mut jobs = Vec::new();
    for (k, t) in [-20.0, 25.0, 65.0].into_iter().enumerate() {
        let mut cfg = sim_config(
            40 + k as u64,
            thermal_support::parameters_at(t),
            "ten-position",
            30.0,
        );
        cfg.sample_rate_hz = 50.0;
        let d = dir.path().join(format!("t{k}"));
        std::fs::create_dir_all(&d).unwrap();
        let run = simulate_run(&d, &cfg, DataFormat::F64le, false, serial, None);
        let mut meta: Value = serde_json::from_slice(&run.metadata).unwrap();
        meta["temperature_c"] = serde_json::json!(t);
        let meta = serde_json::to_vec(&meta).unwrap();
        let r = app
            .upload_multipart(&app.admin, serial, &meta, std::fs::read(&run.data).unwrap())
            .await;
        assert_eq!(r.status(), StatusCode::ACCEPTED);
        let up: Value = r.json().await.unwrap();
        jobs.push(up["job_id"].as_str().unwrap().to_string());
        if k == 0 {
            // One temperature is no model yet.
            let job = app.wait_job(&jobs[0], Duration::from_secs(240)).await;
            assert_eq!(job["state"], "succeeded");
            let r = app
                .get(&app.admin, &format!("/units/{serial}/thermal"))
                .await;
            assert_eq!(r.status(), StatusCode::CONFLICT);
            let result = app.get_result(up["run_id"].as_str().unwrap()).await;
            assert_eq!(result["temperature"]["mean_c"], -20.0);
        }
    }
    for j in &jobs {
        let job = app.wait_job(j, Duration::from_secs(240)).await;
        assert_eq!(job["state"], "succeeded");
    }
    let model = app.get_json(&format!("/units/{serial}/thermal")).await;
    assert_eq!(model["range_c"], serde_json::json!([-20.0, 65.0]));
    assert_eq!(model["runs"].as_array().unwrap().len(), 3);
    assert_eq!(model["parameters"].as_object().unwrap().len(), 24);
    let slope = &model["parameters"]["accel_bias_x"]["linear"];
    let truth = thermal_support::linear()["accel_bias_x"];
    let z = (slope["value"].as_f64().unwrap() - truth) / slope["sigma"].as_f64().unwrap();
    assert!(
        z.abs() < 3.0,
        "accel_bias_x slope {slope} against {truth}: {z:.2} σ"
    );
    // The model as a compensation file: its 25 °C values and its slopes as
    // the thermal terms, JSON and CSV.
    let file = app
        .get_json(&format!("/units/{serial}/thermal/compensation"))
        .await;
    let t = &file["thermal"];
    assert_eq!(t["source"], "unit");
    assert_eq!(t["range_c"], serde_json::json!([-20.0, 65.0]));
    let slope_si = t["linear_per_c"]["accel_bias_m_per_s2"][0]
        .as_f64()
        .unwrap();
    let slope_ug = slope["value"].as_f64().unwrap();
    assert!((slope_si / (slope_ug * 1e-6 * 9.80665) - 1.0).abs() < 1e-9);
    let csv = app
        .get(
            &app.admin,
            &format!("/units/{serial}/thermal/compensation?format=csv"),
        )
        .await
        .text()
        .await
        .unwrap();
    assert!(csv.contains("# thermal (unit)"), "{csv}");
    let station = app.create_token("station").await;
    let r = app.get(&station, &format!("/units/{serial}/thermal")).await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN);
    let r = app
        .get(&station, &format!("/units/{serial}/thermal/compensation"))
        .await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN);
    let r = app.get(&app.admin, "/units/RLG-NONE/thermal").await;
    assert_eq!(r.status(), StatusCode::NOT_FOUND);
    // Only runs after all three: none, so no model.
    let r = app
        .get(
            &app.admin,
            &format!("/units/{serial}/thermal?from=2999-01-01"),
        )
        .await;
    assert_eq!(r.status(), StatusCode::CONFLICT);
    let page = app.sign_in(&app.admin).await;
    let html = page
        .get(&format!("/units/{serial}"))
        .await
        .text()
        .await
        .unwrap();
    assert!(
        html.contains("id=\"thermal\""),
        "the unit page shows the model"
    );
    assert_eq!(
        html.matches("<svg").count(),
        24 + 24,
        "trend and thermal charts"
    );
    app.stop().await;
}

/// A run whose temperature column spans more than 3 °C is calibrated by the
/// server with the in-run thermal states (`--thermal-auto`, on by
/// default): its result carries the SPEC §3a thermal object and its
/// compensation file the thermal terms; the run page shows the
/// coefficients. A soaked run of the same unit is calibrated without them.
#[tokio::test]
async fn a_ramped_run_is_calibrated_with_thermal_states() {
    let app = spawn_app(2).await;
    let dir = tempfile::tempdir().unwrap();
    let serial = "RLG-RAMP";
    // The 9+9 scheme with 60 s dwells (~25 min) at 20 Hz while the chamber
    // rises 2 °C/min from 10 to 30 °C and holds.
    let mut cfg = sim_config(7, ErrorParameters::paper(), "ten-position-9+9", 60.0);
    cfg.sample_rate_hz = 20.0;
    cfg.thermal = Some(thermal_support::ramp_truth());
    cfg.temperature = Some(sinscal_core::model::thermal::TemperatureHistory::Ramp {
        start_c: 10.0,
        rate_c_per_min: 2.0,
        max_c: 30.0,
    });
    let ramped = simulate_run(dir.path(), &cfg, DataFormat::Csv, false, serial, None);
    let (id, job) = app
        .upload_and_calibrate(serial, &ramped, Duration::from_secs(240))
        .await;
    assert_eq!(job["state"], "succeeded", "{job}");
    let result = app.get_result(&id).await;
    assert_eq!(result["model"], "base-24+thermal");
    let thermal = &result["thermal"];
    let range = thermal["range_c"].as_array().unwrap();
    assert!(
        (range[1].as_f64().unwrap() - 30.0).abs() < 1e-9,
        "{thermal}"
    );
    let k = &thermal["gyro_bias_rate"]["x"];
    let truth = thermal_support::GYRO_BIAS_RATE[0];
    let z = (k["value"].as_f64().unwrap() - truth) / k["sigma"].as_f64().unwrap();
    assert!(z.abs() < 4.0, "k_x {k} against {truth}: {z:.2}σ");
    let file = app.get_json(&format!("/runs/{id}/compensation")).await;
    assert_eq!(file["thermal"]["source"], "run");
    assert_eq!(file["provenance"]["model"], "base-24+thermal");
    let page = app.sign_in(&app.admin).await;
    let html = page.get(&format!("/runs/{id}")).await.text().await.unwrap();
    assert!(
        html.contains("id=\"thermal-coefficients\""),
        "the run page shows them"
    );
    assert!(html.contains("gyro_bias_rate"), "and k");

    let soak = dir.path().join("soak");
    std::fs::create_dir_all(&soak).unwrap();
    let mut cfg = sim_config(8, ErrorParameters::paper(), "ten-position", 30.0);
    cfg.sample_rate_hz = 20.0;
    let soaked = simulate_run(&soak, &cfg, DataFormat::F64le, false, serial, None);
    let (id, job) = app
        .upload_and_calibrate(serial, &soaked, Duration::from_secs(240))
        .await;
    assert_eq!(job["state"], "succeeded", "{job}");
    let result = app.get_result(&id).await;
    assert_eq!(result["model"], "base-24");
    assert!(result.get("thermal").is_none());
    app.stop().await;
}
