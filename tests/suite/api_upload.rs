//! Uploads: every kind of bad data is refused with a 4xx problem naming the
//! line or record and leaves nothing behind; re-uploads return the same
//! run; limits, auth and a full queue answer as documented.

use crate::common;

use std::io::Write;

use common::*;
use reqwest::StatusCode;
use sinscal_core::io::data::DataFormat;

const HEADER: &str = "t,dthx,dthy,dthz,dvx,dvy,dvz\n";

fn csv(lines: &[&str]) -> Vec<u8> {
    let mut s = String::from(HEADER);
    for l in lines {
        s.push_str(l);
        s.push('\n');
    }
    s.into_bytes()
}

fn good_lines(n: usize) -> Vec<String> {
    (1..=n)
        .map(|k| format!("{:.2},1e-7,2e-7,3e-7,0,0,0.098", k as f64 * 0.01))
        .collect()
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn f64le(records: &[[f64; 7]]) -> Vec<u8> {
    records
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// Sends `request` as is and reads the reply until the server closes.
async fn raw_http(addr: &str, request: &[u8]) -> String {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(request).await.unwrap();
    let mut out = Vec::new();
    let _ = tokio::time::timeout(std::time::Duration::from_secs(5), s.read_to_end(&mut out)).await;
    String::from_utf8_lossy(&out).into_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_data_is_refused_naming_the_problem_and_nothing_is_stored() {
    let app = spawn_app_with(0, |c| {
        c.max_body_bytes = 4 << 20;
        c.max_decompressed_bytes = 1 << 20;
        // The bomb below is refused by size; the comment-line cap has its
        // own test (api_faults).
        c.max_comment_lines = 1_000_000;
    })
    .await;
    let csv_meta = metadata("RLG-0042", "csv");
    let bin_meta = metadata("RLG-0042", "f64le");
    // 40 s at 100 Hz: the shortest run accepted.
    let good: Vec<String> = good_lines(4001);
    let with = |i: usize, line: &str| {
        let mut l: Vec<&str> = good.iter().map(String::as_str).collect();
        l[i] = line;
        csv(&l)
    };
    let valid_gz = gzip(&csv(&good.iter().map(String::as_str).collect::<Vec<_>>()));
    let mut corrupt_gz = valid_gz.clone();
    // A wrong CRC-32 in the trailer: the text decodes, the check fails.
    let crc_at = corrupt_gz.len() - 8;
    corrupt_gz[crc_at] ^= 0xff;
    let mut bomb = String::from(HEADER);
    bomb.insert_str(
        0,
        &"# padding padding padding padding padding padding padding\n".repeat(60_000),
    );
    let bomb = gzip(bomb.as_bytes());
    assert!(bomb.len() < 1 << 20, "the bomb is small on the wire");
    let rec = |k: f64| [k * 0.01, 1e-7, 0.0, 0.0, 0.0, 0.0, 0.098];
    let mut trailing = f64le(&[rec(1.0), rec(2.0)]);
    trailing.extend_from_slice(&[0u8; 10]);
    let mut nan = [rec(1.0), rec(2.0), rec(3.0)];
    nan[1][4] = f64::NAN;

    // (what, metadata, body, status, words the detail must contain, line, record)
    type Case<'a> = (
        &'a str,
        &'a [u8],
        Vec<u8>,
        u16,
        &'a str,
        Option<u64>,
        Option<u64>,
    );
    let cases: Vec<Case> = vec![
        (
            "not a number",
            &csv_meta,
            with(2, "0.03,abc,0,0,0,0,0.098"),
            422,
            "line 4: column 2 (dthx) is not a number",
            Some(4),
            None,
        ),
        (
            "column count",
            &csv_meta,
            with(2, "0.03,0,0,0,0,0.098"),
            422,
            "line 4: expected 7 columns, found 6",
            Some(4),
            None,
        ),
        (
            "missing header",
            &csv_meta,
            b"0.01,0,0,0,0,0,0.098\n".to_vec(),
            422,
            "line 1: missing header",
            Some(1),
            None,
        ),
        (
            "unknown header",
            &csv_meta,
            b"a,b,c\n".to_vec(),
            422,
            "line 1: unknown header",
            Some(1),
            None,
        ),
        (
            "time not increasing",
            &csv_meta,
            with(3, "0.03,0,0,0,0,0,0.098"),
            422,
            "line 5: time 0.03 does not increase",
            Some(5),
            None,
        ),
        (
            "time step 10.1 % short",
            &csv_meta,
            with(3, "0.03899,0,0,0,0,0,0.098"),
            422,
            "line 5: time step",
            Some(5),
            None,
        ),
        (
            "non-finite",
            &csv_meta,
            with(0, "0.01,inf,0,0,0,0,0.098"),
            422,
            "line 2: column 2 (dthx) is not finite",
            Some(2),
            None,
        ),
        (
            "empty file",
            &csv_meta,
            Vec::new(),
            422,
            "empty file",
            None,
            None,
        ),
        (
            "no records",
            &csv_meta,
            HEADER.as_bytes().to_vec(),
            422,
            "no records after the header on line 1",
            Some(1),
            None,
        ),
        (
            "truncated gzip",
            &csv_meta,
            valid_gz[..valid_gz.len() / 2].to_vec(),
            422,
            "truncated",
            None,
            None,
        ),
        (
            "corrupt gzip",
            &csv_meta,
            corrupt_gz,
            422,
            "corrupt gzip data",
            None,
            None,
        ),
        (
            "gzip bomb",
            &csv_meta,
            bomb,
            413,
            "exceeds the limit of 1048576 bytes (decompressed)",
            None,
            None,
        ),
        (
            "f64le trailing bytes",
            &bin_meta,
            trailing,
            422,
            "record 3: the file ends with 10 trailing bytes",
            None,
            Some(3),
        ),
        (
            "f64le NaN",
            &bin_meta,
            f64le(&nan),
            422,
            "record 2",
            None,
            Some(2),
        ),
        (
            "f64le empty",
            &bin_meta,
            Vec::new(),
            422,
            "no f64le records",
            None,
            None,
        ),
    ];
    for (what, meta, body, status, words, line, record) in cases {
        for raw in [false, true] {
            let r = if raw {
                app.upload_raw(&app.admin, "RLG-0042", meta, body.clone())
                    .await
            } else {
                app.upload_multipart(&app.admin, "RLG-0042", meta, body.clone())
                    .await
            };
            let (s, p) = problem(r).await;
            let detail = p["detail"].as_str().unwrap();
            assert_eq!(s.as_u16(), status, "{what} (raw {raw}): {detail}");
            assert!(
                detail.contains(words),
                "{what} (raw {raw}): {detail:?} lacks {words:?}"
            );
            if let Some(l) = line {
                assert_eq!(p["line"], l, "{what}: {p}");
            }
            if let Some(n) = record {
                assert_eq!(p["record"], n, "{what}: {p}");
            }
        }
    }

    // Bodies over the limit are refused from their Content-Length, before
    // they are read (so the test speaks HTTP by hand: a client that goes on
    // writing a refused body sees the connection close under it).
    let addr = app
        .base
        .trim_start_matches("http://")
        .trim_end_matches("/api/v1")
        .to_string();
    for ct in [
        "application/octet-stream",
        "multipart/form-data; boundary=xyz",
    ] {
        let head = format!(
            "POST /api/v1/units/RLG-0042/runs HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {}\r\n\
             X-Sinscal-Metadata: {}\r\nContent-Type: {ct}\r\nContent-Length: {}\r\n\r\n",
            app.admin,
            String::from_utf8(csv_meta.clone()).unwrap(),
            5u64 << 20
        );
        let reply = raw_http(&addr, head.as_bytes()).await;
        assert!(reply.starts_with("HTTP/1.1 413"), "{ct}: {reply}");
        assert!(reply.contains("application/problem+json"), "{ct}: {reply}");
    }

    // Metadata and request problems.
    // Stamps as loggers write them (SPEC §2a): steps 9.9 % off nominal
    // either way, and a gap (records 101 to 110 lost), all accepted. (The
    // shortest run is counted in records: 4001 of them.)
    let long = good_lines(4011);
    let mut stamped: Vec<&str> = long.iter().map(String::as_str).collect();
    stamped[49] = "0.50099,1e-7,2e-7,3e-7,0,0,0.098";
    stamped[59] = "0.59901,1e-7,2e-7,3e-7,0,0,0.098";
    stamped.drain(100..110);
    let valid = csv(&stamped);
    let other = metadata("RLG-0043", "csv");
    let meta_cases: Vec<(&str, &str, Vec<u8>, u16, &str)> = vec![
        ("malformed metadata", "RLG-0042", b"{\"unit_serial\": ".to_vec(), 422, "metadata"),
        ("missing rate", "RLG-0042", br#"{"unit_serial":"RLG-0042","latitude_deg":1,"longitude_deg":2,"height_m":3}"#.to_vec(), 422, "sample_rate_hz"),
        ("serial mismatch", "RLG-0042", other, 422, "differs from the unit in the path"),
        ("bad rate", "RLG-0042", br#"{"unit_serial":"RLG-0042","sample_rate_hz":-5,"latitude_deg":1,"longitude_deg":2,"height_m":3}"#.to_vec(), 422, "sample_rate_hz"),
        ("bad serial in path", "..evil", metadata("..evil", "csv"), 400, "must start with a letter or digit"),
    ];
    for (what, serial, meta, status, words) in meta_cases {
        let (s, p) = problem(
            app.upload_multipart(&app.admin, serial, &meta, valid.clone())
                .await,
        )
        .await;
        assert_eq!(s.as_u16(), status, "{what}: {p}");
        assert!(p["detail"].as_str().unwrap().contains(words), "{what}: {p}");
    }
    // No metadata at all on a raw body; a form without its data part.
    let r = app
        .http
        .post(app.url("/units/RLG-0042/runs"))
        .bearer_auth(&app.admin)
        .body(valid.clone())
        .send()
        .await
        .unwrap();
    let (s, p) = problem(r).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(p["detail"].as_str().unwrap().contains("no metadata"), "{p}");
    let form = reqwest::multipart::Form::new().part(
        "metadata",
        reqwest::multipart::Part::bytes(csv_meta.clone()),
    );
    let r = app
        .http
        .post(app.url("/units/RLG-0042/runs"))
        .bearer_auth(&app.admin)
        .multipart(form)
        .send()
        .await
        .unwrap();
    let (s, p) = problem(r).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(
        p["detail"].as_str().unwrap().contains("no `data` part"),
        "{p}"
    );

    // Nothing stored: no unit, no run file, no partial file.
    assert_eq!(app.units().await["total"], 0);
    assert!(app.stored_files().is_empty(), "{:?}", app.stored_files());
    assert!(app
        .metrics()
        .await
        .contains("sinscal_uploads_total{outcome=\"accepted\"} 0"));

    // And a valid file after all that is accepted, data before metadata too.
    let form = reqwest::multipart::Form::new()
        .part("data", reqwest::multipart::Part::bytes(valid))
        .part(
            "metadata",
            reqwest::multipart::Part::bytes(csv_meta.clone()),
        );
    let r = app
        .http
        .post(app.url("/units/RLG-0042/runs"))
        .bearer_auth(&app.admin)
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let run: serde_json::Value = r.json().await.unwrap();
    assert_eq!(
        app.get_run(run["run_id"].as_str().unwrap()).await["records"],
        4001
    );
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reupload_returns_the_same_run_and_one_job() {
    let app = spawn_app(0).await;
    let dir = tempfile::tempdir().unwrap();
    let run = short_run(dir.path(), 7, DataFormat::F64le, "RLG-0042");
    let data = std::fs::read(&run.data).unwrap();

    let first = app
        .upload_multipart(&app.admin, "RLG-0042", &run.metadata, data.clone())
        .await;
    assert_eq!(first.status(), StatusCode::ACCEPTED);
    let location = first.headers()["location"].to_str().unwrap().to_string();
    let first: serde_json::Value = first.json().await.unwrap();
    assert_eq!(
        location,
        format!("/api/v1/runs/{}", first["run_id"].as_str().unwrap())
    );
    assert_eq!(first["sha256"], sha256_hex(&data));

    // Same bytes again, this time as a raw body: the same run and job.
    let again = app
        .upload_raw(&app.admin, "RLG-0042", &run.metadata, data.clone())
        .await;
    assert_eq!(again.status(), StatusCode::OK);
    let again: serde_json::Value = again.json().await.unwrap();
    assert_eq!(again["run_id"], first["run_id"]);
    assert_eq!(again["job_id"], first["job_id"]);
    assert_eq!(again["created"], false);

    let unit = app.unit("RLG-0042").await;
    assert_eq!(unit["runs"], 1);
    assert_eq!(unit["jobs"]["queued"], 1);
    assert_eq!(app.stored_files().len(), 1);

    // The stored file is the uploaded bytes.
    let stored = app.get_run(first["run_id"].as_str().unwrap()).await;
    assert_eq!(stored["sha256"], sha256_hex(&data));
    assert_eq!(stored["size_bytes"], data.len());
    let file = &app.stored_files()[0];
    assert_eq!(
        sha256_hex(&std::fs::read(app.data_dir.path().join("runs").join(file)).unwrap()),
        sha256_hex(&data)
    );
    app.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn roles_are_enforced_and_a_full_queue_answers_503() {
    let app = spawn_app_with(0, |c| c.max_queue = 1).await;
    let station = app.create_token("station").await;
    let engineer = app.create_token("engineer").await;
    let meta = metadata("RLG-0042", "csv");
    let data = csv(&good_lines(4001)
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());

    let r = app.http.get(app.url("/units")).send().await.unwrap();
    assert_eq!(r.headers()["www-authenticate"], "Bearer");
    assert_eq!(problem(r).await.0, StatusCode::UNAUTHORIZED);
    let r = app.get("sinscal_00", "/units").await;
    assert_eq!(problem(r).await.0, StatusCode::UNAUTHORIZED);
    assert_eq!(
        problem(app.get(&station, "/units").await).await.0,
        StatusCode::FORBIDDEN
    );
    assert_eq!(
        problem(app.get(&engineer, "/tokens").await).await.0,
        StatusCode::FORBIDDEN
    );
    let r = app
        .upload_multipart(&engineer, "RLG-0042", &meta, data.clone())
        .await;
    // Refused before its body was read: the connection is not reused.
    assert_eq!(r.headers()["connection"], "close");
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    assert_eq!(app.get(&engineer, "/units").await.status(), StatusCode::OK);
    assert_eq!(app.get("", "/healthz").await.status(), StatusCode::OK);
    // The operations endpoints at the root too, with the same rules.
    let root = app.base.trim_end_matches("/api/v1").to_string();
    for path in ["/healthz", "/readyz"] {
        let r = app.http.get(format!("{root}{path}")).send().await.unwrap();
        assert_eq!(r.status(), StatusCode::OK, "{path}");
    }
    let r = app
        .http
        .get(format!("{root}/metrics"))
        .send()
        .await
        .unwrap();
    assert_eq!(problem(r).await.0, StatusCode::UNAUTHORIZED);
    let r = app
        .http
        .get(format!("{root}/metrics"))
        .bearer_auth(&engineer)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::OK);

    let r = app
        .upload_multipart(&station, "RLG-0042", &meta, data.clone())
        .await;
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let run: serde_json::Value = r.json().await.unwrap();
    // A station follows its upload, but reading results is for engineers.
    let run_id = run["run_id"].as_str().unwrap();
    assert_eq!(
        app.get(&station, &format!("/runs/{run_id}")).await.status(),
        StatusCode::OK
    );
    let r = app.get(&station, &format!("/runs/{run_id}/result")).await;
    assert_eq!(problem(r).await.0, StatusCode::FORBIDDEN);
    let r = app.get(&engineer, &format!("/runs/{run_id}/result")).await;
    assert_eq!(
        problem(r).await.0,
        StatusCode::CONFLICT,
        "no result while queued"
    );

    // The queue holds one job: the next distinct run is refused, not stored.
    let other = csv(&good_lines(4002)
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());
    let r = app
        .upload_multipart(&station, "RLG-0042", &meta, other)
        .await;
    assert_eq!(r.headers()["retry-after"], "30");
    assert_eq!(problem(r).await.0, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(app.stored_files().len(), 1);

    // Cancel the queued job: it is never run.
    let job_id = run["job_id"].as_str().unwrap();
    let r = app.cancel_job(job_id).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(app.get_job(job_id).await["state"], "cancelled");
    assert_eq!(
        app.runner.try_run_next_job(0).await.unwrap(),
        sinscal_server::jobs::Outcome::Empty
    );

    // A revoked token stops working.
    let tokens: serde_json::Value = app.get_json("/tokens").await;
    let station_id = tokens
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["role"] == "station")
        .unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let r = app
        .http
        .delete(app.url(&format!("/tokens/{station_id}")))
        .bearer_auth(&app.admin)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::NO_CONTENT);
    assert_eq!(
        problem(app.get(&station, &format!("/runs/{run_id}")).await)
            .await
            .0,
        StatusCode::UNAUTHORIZED
    );
    app.stop().await;
}
